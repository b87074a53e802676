#!/usr/bin/env python3
"""Bark for a whole tree (issue 34): continuity across the atlas's chart borders, fissures along
the branches, validity of the glb, speed.

    .venv/bin/python benchmarks/bench_tree.py [--size 1024] [--photo oak_furrowed_moss_01.jpg]
        [--runs 1] [--mesh MESH] [--preview docs/images/tree_preview.png] [--json out.json]

One tree (the built-in one, or ``--mesh``), its atlas of ``--size`` made by
``barkgen.pipeline.make_tree`` from one shared photo, seed 0. Measured:

- chart borders, sampled on the surface: each gutter texel is linked to the texel of the other
  chart at its surface point; the step between that texel and the last texel of the gutter's
  own chart (two surface neighbours on either side of the border) over the step between that
  last texel and the one beyond it inside its chart (the same distance, the other way): the
  ratio of the mean steps, for the colour (CIELAB) and the displacement; the same run without
  the links (each chart synthesized as if alone) as the baseline;
- fissures along the branches: the angle between the texture's local dominant orientation
  (structure tensor over a fissure period) and the branch axis carried into the atlas, over the
  chart texels at least a fissure period from a border: median and 90th percentile;
- ``tree.glb`` through the Khronos glTF validator (npm gltf-validator, installed by
  ``scripts/test.sh``): errors / warnings;
- seconds of ``make_tree`` (median of ``--runs``) and of its stages.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("BARKGEN_SHARED", REPO.parent / "shared"))
VALIDATOR = REPO / ".cache" / "node" / "node_modules" / "gltf-validator"
CHECK = """
const fs = require("fs");
const validator = require(process.argv[2]);
validator.validateBytes(new Uint8Array(fs.readFileSync(process.argv[1])), {maxIssues: 100}).then((r) => {
  console.log(JSON.stringify({errors: r.issues.numErrors, warnings: r.issues.numWarnings}));
});
"""


def validate(glb: bytes) -> str:
    node = shutil.which("node")
    if node is None or not VALIDATOR.is_dir():
        return "no validator (scripts/test.sh installs it)"
    with tempfile.NamedTemporaryFile(suffix=".glb") as handle:
        handle.write(glb)
        handle.flush()
        out = subprocess.run(
            [node, "-e", CHECK, handle.name, str(VALIDATOR)], capture_output=True, text=True, timeout=300
        )
    report = json.loads(out.stdout)
    return f"{report['errors']}/{report['warnings']}"


def border_steps(texels, images: dict[str, np.ndarray]) -> dict[str, float]:
    """Mean step across chart borders (on the surface) over the mean step inside charts, per map."""
    from scipy import ndimage

    covered = texels.covered
    h, w = covered.shape
    _, (near_rows, near_cols) = ndimage.distance_transform_edt(~covered, return_indices=True)
    gy, gx = np.divmod(texels.links.target, w)
    sy, sx = np.divmod(texels.links.source, w)
    ay, ax = near_rows[gy, gx], near_cols[gy, gx]  # the last texel of the gutter's own chart
    by, bx = 2 * ay - gy, 2 * ax - gx  # as far inside the chart, the other way
    ok = (by >= 0) & (by < h) & (bx >= 0) & (bx < w)
    ok[ok] &= covered[by[ok], bx[ok]] & (texels.triangle[by[ok], bx[ok]] >= 0)
    ok &= (gy != ay) | (gx != ax)
    ratios = {}
    for name, image in images.items():
        values = image.reshape(h, w, -1).astype(np.float64)
        across = np.linalg.norm(values[ay[ok], ax[ok]] - values[sy[ok], sx[ok]], axis=1)
        inside = np.linalg.norm(values[ay[ok], ax[ok]] - values[by[ok], bx[ok]], axis=1)
        ratios[name] = float(across.mean() / max(inside.mean(), 1e-12))
    return ratios


def fissure_error(texels, texture: np.ndarray, photo: np.ndarray) -> tuple[float, float]:
    from scipy import ndimage

    sys.path.insert(0, str(REPO / "benchmarks"))
    from bench_flow import angle_error, dominant, fissure_period, orientation

    period = fissure_period(photo)
    own = dominant(orientation(photo, period))
    measured = orientation(texture, period)
    inner = ndimage.distance_transform_edt(texels.covered) >= period
    error = angle_error(measured[inner], own + texels.flow[inner])
    return float(np.median(error)), float(np.percentile(error, 90))


def lab(image: np.ndarray) -> np.ndarray:
    from barkgen.color import rgb_to_lab

    return rgb_to_lab(image.astype(np.float32) / (65535.0 if image.dtype == np.uint16 else 255.0))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=1024)
    parser.add_argument("--photo", default="oak_furrowed_moss_01.jpg")
    parser.add_argument("--runs", type=int, default=1)
    parser.add_argument("--mesh", type=Path, default=None)
    parser.add_argument("--preview", type=Path, default=None, help="write the four views here")
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    sys.path.insert(0, str(REPO / "src"))
    from barkgen.io import encode_glb, read_image, write_png
    from barkgen.pipeline import GenerateOptions, make_tree
    from barkgen.render.mesh import four_views
    from barkgen.tree import read_tree_mesh

    photo = read_image(SHARED / "data" / "bark" / args.photo)
    options = GenerateOptions(size=(args.size, args.size), material=True, seed=0)
    mesh = read_tree_mesh(args.mesh, resolution=args.size) if args.mesh else None
    seconds, tree = [], None
    for _ in range(max(1, args.runs)):
        t0 = time.perf_counter()
        tree = make_tree(photo, options, mesh=mesh)
        seconds.append(time.perf_counter() - t0)
    assert tree is not None
    # the baseline: the same atlas without the chart-border links
    from barkgen.pipeline import generate

    t0 = time.perf_counter()
    texels = tree.texels
    unlinked = generate(photo, options, flow=texels.flow, flow_scale=texels.scale)
    baseline_s = time.perf_counter() - t0
    material = tree.result.material
    maps = {"colour": lab(tree.result.texture), "displacement": material.height}
    base_maps = {"colour": lab(unlinked.texture), "displacement": unlinked.material.height}
    steps, base_steps = border_steps(texels, maps), border_steps(texels, base_maps)
    median_error, p90_error = fissure_error(texels, tree.result.texture, photo)
    row = {
        "mesh": tree.mesh.source,
        "triangles": len(tree.mesh.faces),
        "atlas": args.size,
        "covered": float(texels.covered.mean()),
        "links": int(texels.links.target.size),
        "copies": tree.result.report["flow"]["copies"],
        "colour step ratio": steps["colour"],
        "displacement step ratio": steps["displacement"],
        "colour step ratio without links": base_steps["colour"],
        "displacement step ratio without links": base_steps["displacement"],
        "fissure error median": median_error,
        "fissure error p90": p90_error,
        "glb errors/warnings": validate(encode_glb(tree.mesh, material)),
        "seconds (median)": statistics.median(seconds),
        "stages": tree.result.report["timings_s"],
        "baseline s": baseline_s,
    }
    for key, value in row.items():
        print(f"| {key} | {value:.3g} |" if isinstance(value, float) else f"| {key} | {value} |")
    if args.preview:
        write_png(args.preview, four_views(tree.mesh, material, size=512))
    if args.json:
        args.json.write_text(json.dumps(row, indent=2, default=str))


if __name__ == "__main__":
    main()
