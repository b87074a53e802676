#!/usr/bin/env python3
"""Scanned sets in, engine-ready sets out (issue 32): the four scanned sets of the team's data
folder (``$BARKGEN_SHARED/data/bark`` colour + ``data/bark_maps`` normal, AO, roughness; 1024²)
each made into a tileable set of ``--size`` (default 2048²), seed 0.

    .venv/bin/python benchmarks/bench_scanned.py [--quick] [--size 2048] [--scans oak,pine]

Per scan, in one process (kernels compiled first):

- seconds of ``generate(scan=...)`` with the material set beside ``generate`` of the colour alone
  (no material set), and their ratio (the acceptance: <= 1.5x);
- normals: the largest deviation of |n| from 1; the angle to the scan's normals re-applied
  through the reference map, inside the pieces (pixels >= 8 px from a border between pieces,
  on the torus): its largest and median value;
- AO and roughness inside the pieces: the largest difference to the scan's own;
- step ratios (:func:`barkgen.evaluate.border_step_ratio`: mean step across the borders between
  pieces over inside them) of the colour, NormalGL, displacement, AO and roughness (the
  acceptance: <= 1.5);
- every preset encoded: the packed channels (ORM, Unity's MaskMap) against the separate maps
  (exact or not), the Blender preset's MaterialX validated by MaterialX;
- the trunk's glb of the set through the Khronos validator (errors / warnings), when node and
  ``.cache/node/node_modules/gltf-validator`` (scripts/test.sh) are there.

- one bark at three sizes (``--sizes 1k,2k,4k``, oak, seed 0): the colour distance
  (:func:`barkgen.evaluate.colour_distance`, the 1-D Wasserstein distance averaged over L, a, b) of
  the 1K set's colour against the 4K set's colour area-averaged to 1K (the acceptance: <= 0.2
  summed over L, a and b, i.e. <= 0.067 averaged), and
  against the 4K colour itself (their histograms: the 1K is the same bark, smaller); skipped
  with ``--quick``.

``--quick``: 1024² outputs, two scans (about 2 minutes).

``--cases`` (issue 66): any scanned set taken in. The oak scan (colour, normal, AO, roughness;
its height the normals integrated on the torus, gloss and specular its roughness inverted)
area-averaged to ``--case-size`` (default 512) and renamed as each library names its sets
(ambientCG, Poly Haven with ``arm``, Megascans with gloss and specular, Substance, CC0
Textures, a game pack's ``_cc/_nm/_hm/_sc``, plain ``albedo/nrm/bump/glossiness``), then maps
of three sizes (colour 1/1, normal and roughness 1/4, height and AO 1/8), a specular map, a
gloss map, a DirectX normal named only ``Normal`` (told from the height) and a height that does
not tile (it climbs 40 % down the rows) beside a colour that does. Each set made tileable at
twice its size, seed 0; per output map the longest straight line
(:func:`barkgen.evaluate.longest_line`, px, tiled) against the input set's own at the output's
size (the scan's map at the colour's size as the run uses it, repeated 2x2, tiled: a line of
the input's own runs on across its copies, as it may across the output's pieces; a map that does
not tile shows its edge there). ``--save DIR`` writes every map of both (16-bit
PNG) for the team's referee.
"""

from __future__ import annotations

import argparse
import io
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("BARKGEN_SHARED", REPO.parent / "shared"))
SCANS = ("birch_smooth_lenticels_01", "oak_furrowed_moss_01", "pine_plated_01", "willow_furrowed_01")
VALIDATOR = REPO / ".cache" / "node" / "node_modules" / "gltf-validator"
CHECK = (
    "const v=require(process.argv[2]);v.validateBytes(new Uint8Array(require('fs').readFileSync(process.argv[1])))"
    ".then(r=>console.log(JSON.stringify([r.issues.numErrors,r.issues.numWarnings])));"
)


def scan_folder(root: Path, name: str) -> Path:
    folder = root / name
    folder.mkdir()
    shutil.copy(SHARED / "data" / "bark" / f"{name}.jpg", folder / f"{name}.jpg")
    for kind in ("normal", "ao", "roughness"):
        shutil.copy(SHARED / "data" / "bark_maps" / f"{name}_{kind}.jpg", folder / f"{name}_{kind}.jpg")
    return folder


def inside_pieces(references: np.ndarray, shape, wrap, band: int = 8) -> np.ndarray:
    import cv2

    from barkgen.synth import Canvas, piece_borders

    inside = (~piece_borders(references, shape, Canvas(references.shape[:2], tile=True, exemplar_wrap=wrap))).astype(
        np.uint8
    )
    pad = band + 1
    return cv2.distanceTransform(np.pad(inside, pad, mode="wrap"), cv2.DIST_L2, 3)[pad:-pad, pad:-pad] >= band


def step_ratios(result, exemplar_shape, images: dict[str, np.ndarray]) -> dict[str, float | None]:
    """The step ratio of each map across the borders between pieces, the scan taken as wrapping
    along the axes it wraps along (a piece running on across the scan's edge is then one piece,
    as the solver used it)."""
    from barkgen.evaluate import border_step_ratio

    wraps = result.report["exemplar_wrap"]
    periods = tuple(int(n) if w else 0 for n, w in zip(exemplar_shape, wraps))
    return {
        name: border_step_ratio(pixels, result.references, tile=True, exemplar_wrap=periods)
        for name, pixels in images.items()
    }


def packed_exact(material) -> bool:
    from PIL import Image

    from barkgen.io import encode_material

    def pix(data):
        return np.asarray(Image.open(io.BytesIO(data)))

    plain = encode_material(material, "b")
    ao, rough = pix(plain["b_AmbientOcclusion.png"]), pix(plain["b_Roughness.png"])
    ok = True
    for preset in ("unreal", "gltf"):
        orm = pix(encode_material(material, "b", preset)["b_ORM.png"])
        ok &= bool((orm[..., 0] == ao).all() and (orm[..., 1] == rough).all())
    mask = pix(encode_material(material, "b", "unity")["b_MaskMap.png"])
    ok &= bool((mask[..., 1] == ao).all() and (mask[..., 3] == 255 - rough).all())
    encode_material(material, "b", "blender")  # its .mtlx is validated by MaterialX as it is made
    return ok


def validate_glb(material) -> str:
    from barkgen.io import encode_glb
    from barkgen.render import trunk_mesh

    node = shutil.which("node")
    if node is None or not VALIDATOR.is_dir():
        return "n/a"
    with tempfile.NamedTemporaryFile(suffix=".glb") as f:
        f.write(encode_glb(trunk_mesh(material, segments=64), material))
        f.flush()
        out = subprocess.run([node, "-e", CHECK, f.name, str(VALIDATOR)], capture_output=True, text=True)
    errors, warnings = json.loads(out.stdout)
    return f"{errors}/{warnings}"


def measure(name: str, size: int, root: Path) -> dict:
    from barkgen.io import read_scanned_set
    from barkgen.pipeline import GenerateOptions, generate

    scan = read_scanned_set(scan_folder(root, name))
    options = GenerateOptions(size=(size, size), tile=True, seed=0)
    t0 = time.perf_counter()
    generate(scan.color, options)
    colour_only = time.perf_counter() - t0
    t0 = time.perf_counter()
    result = generate(scan.color, GenerateOptions(size=(size, size), tile=True, seed=0, material=True), scan=scan)
    with_set = time.perf_counter() - t0
    m, refs = result.material, result.references
    wrap = tuple(result.report["exemplar_wrap"])
    deep = inside_pieces(refs, scan.shape, wrap)
    copied = scan.normals[refs[..., 0], refs[..., 1]].astype(np.float64)
    angle = np.degrees(np.arccos(np.clip((m.normals * copied).sum(2), -1, 1)))[deep]
    local = max(
        np.abs(getattr(m, k) - getattr(scan, k)[refs[..., 0], refs[..., 1]])[deep].max() for k in ("ao", "roughness")
    )
    images = m.images("b")
    ratios = step_ratios(
        result,
        scan.shape,
        {k: images[f"b_{k}.png"] for k in ("Color", "NormalGL", "Displacement", "AmbientOcclusion", "Roughness")},
    )
    return {
        "scan": name.split("_")[0],
        "wraps": "".join("yx"[i] for i in range(2) if wrap[i]) or "no",
        "set s": with_set,
        "colour s": colour_only,
        "ratio": with_set / colour_only,
        "|n|-1 max": float(np.abs(np.linalg.norm(m.normals, axis=2) - 1).max()),
        "angle max/median": f"{angle.max():.3f} / {np.median(angle):.3f}",
        "inside": float(deep.mean()),
        "AO, rough max diff": float(local),
        "worst step ratio": max(v for v in ratios.values() if v is not None),
        "steps": ratios,
        "packed exact": packed_exact(m),
        "glb errors/warnings": validate_glb(m),
    }


def sizes_case(root: Path) -> dict:
    """The set of sizes from one seed: 1K, 2K and 4K of oak, compared as the issue asks."""
    import cv2

    from barkgen.evaluate import colour_distance
    from barkgen.io import read_scanned_set
    from barkgen.pipeline import GenerateOptions, generate, sized_options

    scan = read_scanned_set(scan_folder(root, "oak_furrowed_moss_01"))
    options = sized_options(GenerateOptions(tile=True, seed=0), [1024, 2048, 4096])
    t0 = time.perf_counter()
    material = generate(scan.color, options, scan=scan).material
    seconds = time.perf_counter() - t0
    small = material.resampled((1024, 1024)).color
    reference = cv2.resize(material.color, (1024, 1024), interpolation=cv2.INTER_AREA)
    return {
        "4K set s": seconds,
        "colour distance 1K vs 4K area-averaged": colour_distance(small, reference),
        "colour distance 1K vs 4K": colour_distance(small, material.color),
    }


CASES = (
    "ambientcg",
    "polyhaven",
    "megascans",
    "substance",
    "cc0textures",
    "gamepack",
    "plain",
    "three sizes",
    "specular",
    "gloss",
    "dx normal",
    "height not tiling",
)
#: naming style -> (map -> file name)
STYLES = {
    "ambientcg": {
        "color": "Bark001_1K_Color.png",
        "normal": "Bark001_1K_NormalGL.png",
        "height": "Bark001_1K_Displacement.png",
        "roughness": "Bark001_1K_Roughness.png",
        "ao": "Bark001_1K_AmbientOcclusion.png",
    },
    "polyhaven": {
        "color": "bark_brown_02_diff_1k.png",
        "normal": "bark_brown_02_nor_gl_1k.png",
        "height": "bark_brown_02_disp_1k.png",
        "arm": "bark_brown_02_arm_1k.png",
    },
    "megascans": {
        "color": "Bark_vdqmbhw_1K_Albedo.png",
        "normal": "Bark_vdqmbhw_1K_Normal.png",
        "height": "Bark_vdqmbhw_1K_Displacement.png",
        "gloss": "Bark_vdqmbhw_1K_Gloss.png",
        "specular": "Bark_vdqmbhw_1K_Specular.png",
        "ao": "Bark_vdqmbhw_1K_AO.png",
        "cavity": "Bark_vdqmbhw_1K_Cavity.png",
    },
    "substance": {
        "color": "OakBark_BaseColor.png",
        "normal": "OakBark_Normal.png",
        "height": "OakBark_Height.png",
        "roughness": "OakBark_Roughness.png",
        "ao": "OakBark_AmbientOcclusion.png",
        "metalness": "OakBark_Metallic.png",
    },
    "cc0textures": {
        "color": "Bark01_col.png",
        "normal": "Bark01_nrm.png",
        "height": "Bark01_disp.png",
        "roughness": "Bark01_rgh.png",
        "ao": "Bark01_AO.png",
    },
    "gamepack": {
        "color": "oakbark_cc.png",
        "normal": "oakbark_nm.png",
        "height": "oakbark_hm.png",
        "specular": "oakbark_sc.png",
    },
    "plain": {
        "color": "oak bark albedo.png",
        "normal": "oak bark nrm.png",
        "height": "oak bark bump.png",
        "gloss": "oak bark glossiness.png",
    },
}


def source_maps(size: int, name: str = "oak_furrowed_moss_01") -> dict[str, np.ndarray]:
    """The scan's maps at ``size`` px (area-averaged), as file pixels."""
    import cv2

    from barkgen._shared.arrays import Boundary
    from barkgen.io import read_image
    from barkgen.material import integrate_normals
    from barkgen.material.maps import decode_normals, encode_normals

    def small(image, s=size):
        out = cv2.resize(image, (s, s), interpolation=cv2.INTER_AREA)
        return out[:, :, None] if out.ndim == 2 else out

    color = small(read_image(SHARED / "data" / "bark" / f"{name}.jpg"))
    normals = decode_normals(small(read_image(SHARED / "data" / "bark_maps" / f"{name}_normal.jpg")))
    height = integrate_normals(normals, Boundary(True))
    height = (height - height.min()) / max(float(np.ptp(height)), 1e-6)
    ao = small(read_image(SHARED / "data" / "bark_maps" / f"{name}_ao.jpg"))[..., :1]
    rough = small(read_image(SHARED / "data" / "bark_maps" / f"{name}_roughness.jpg"))[..., :1]
    return {
        "color": color,
        "normal": encode_normals(normals, 8),
        "height": np.round(height * 65535).astype(np.uint16)[..., None],
        "roughness": rough,
        "ao": ao,
        "gloss": 255 - rough,
        "specular": 255 - rough,
        "metalness": np.zeros_like(rough),
        "cavity": ao,
        "arm": np.concatenate([ao, rough, np.zeros_like(rough)], axis=2),
    }


def case_folder(root: Path, case: str, size: int) -> Path:
    """A folder holding the set of one ``case`` (see the module)."""
    from barkgen.io import write_png

    m = source_maps(size)
    if case in STYLES:
        files = {name: m[kind] for kind, name in STYLES[case].items()}
    elif case == "three sizes":
        quarter, eighth = source_maps(size // 4), source_maps(size // 8)
        files = {
            "o_Color.png": m["color"],
            "o_NormalGL.png": quarter["normal"],
            "o_Roughness.png": quarter["roughness"],
            "o_Height.png": eighth["height"],
            "o_AO.png": eighth["ao"],
        }
    elif case == "specular":
        files = {"o_Color.png": m["color"], "o_NormalGL.png": m["normal"], "o_Specular.png": m["specular"]}
    elif case == "gloss":
        files = {"o_Color.png": m["color"], "o_NormalGL.png": m["normal"], "o_Gloss.png": m["gloss"]}
    elif case == "dx normal":
        normal = m["normal"].copy()
        normal[..., 1] = 255 - normal[..., 1]
        files = {"o_Color.png": m["color"], "o_Normal.png": normal, "o_Height.png": m["height"]}
    else:  # a height that does not tile
        ramp = m["height"] / 65535 * 0.6 + 0.4 * np.linspace(0, 1, size)[:, None, None]
        files = {
            "o_Color.png": m["color"],
            "o_NormalGL.png": m["normal"],
            "o_Height.png": np.round(ramp * 65535).astype(np.uint16),
        }
    folder = root / case.replace(" ", "_")
    folder.mkdir()
    for name, pixels in files.items():
        write_png(folder / name, pixels)
    return folder


def measure_case(case: str, size: int, root: Path, save: Path | None) -> dict:
    """One scanned set of ``case`` made tileable at twice its size: the longest line of every
    output map against the input set's own."""
    import warnings

    from barkgen.evaluate import longest_line
    from barkgen.io import read_scanned_set
    from barkgen.material import scanned_material
    from barkgen.material.maps import encode_normals
    from barkgen.pipeline import GenerateOptions, generate

    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        scan = read_scanned_set(case_folder(root, case, size))
    out_size = (2 * scan.shape[0], 2 * scan.shape[1])
    t0 = time.perf_counter()
    result = generate(scan.color, GenerateOptions(size=out_size, tile=True, seed=0, material=True), scan=scan)
    seconds = time.perf_counter() - t0
    wrap = tuple(result.report["exemplar_wrap"])
    source = scanned_material(scan, wrap=wrap)
    material = result.material
    lines = {}
    for kind in ("color", "height", "normals", "ao", "roughness"):
        own = getattr(source, kind)
        repeated = np.tile(own, (2, 2) + (1,) * (own.ndim - 2))  # the input's own, at the output's size
        lines[kind] = (longest_line(getattr(material, kind), tile=True), longest_line(repeated, tile=True))
    if save is not None:
        from barkgen.io import write_png

        folder = save / case.replace(" ", "_")
        folder.mkdir(parents=True, exist_ok=True)
        for side, mset in (("in", source), ("out", material)):
            for kind in ("height", "ao", "roughness"):
                values = getattr(mset, kind).astype(np.float64)
                values = (values - values.min()) / max(float(np.ptp(values)), 1e-12)
                write_png(folder / f"{side}_{kind}.png", np.round(values * 65535).astype(np.uint16)[..., None])
            write_png(folder / f"{side}_normals.png", encode_normals(mset.normals, 16))
    info = scan.info
    not_wrapped = source.scan_info.get("not_wrapped", {})
    return {
        "case": case,
        "maps": ", ".join(sorted(set(scan.maps))),
        "sizes": " ".join(f"{w}" for w, _ in info.get("sizes", {}).values()) or "-",
        "normals": f"{info.get('normal_convention', '-')} ({info.get('normal_convention_from', '-')})",
        "roughness from": info.get("roughness_from", "estimate"),
        "not wrapped": ", ".join(f"{k} {v}" for k, v in not_wrapped.items()) or "-",
        "left out": len([w for w in said if "left out" in str(w.message)]),
        "s": seconds,
        **{f"{kind} out/in": f"{o}/{i}" + (" !" if o > i else "") for kind, (o, i) in lines.items()},
        "worst out-in": max(o - i for o, i in lines.values()),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--size", type=int, default=None)
    parser.add_argument("--scans", default=None, help="comma-separated prefixes (birch,oak,pine,willow)")
    parser.add_argument("--json", type=Path, default=None)
    parser.add_argument("--cases", action="store_true", help="the scanned sets of every naming style (issue 66) only")
    parser.add_argument("--case-size", type=int, default=512)
    parser.add_argument("--save", type=Path, default=None, help="with --cases: write every map in and out here")
    args = parser.parse_args()
    size = args.size or (1024 if args.quick else 2048)
    names = [n for n in SCANS if args.scans is None or n.split("_")[0] in args.scans.split(",")]
    if args.quick and args.scans is None:
        names = names[1:3]
    if not (SHARED / "data" / "bark_maps").is_dir():
        raise SystemExit(f"needs the team's data folder at {SHARED} (set BARKGEN_SHARED)")
    import barkgen

    barkgen.warm_up()
    if args.cases:
        cases(args)
        return
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            rows.append(measure(name, size, Path(tmp)))
            print(f"{name}: done", file=sys.stderr)
    keys = [k for k in rows[0] if k != "steps"]
    print(f"scanned sets -> {size}x{size} tileable, seed 0")
    print("| " + " | ".join(keys) + " |")
    print("|" + "---|" * len(keys))
    for row in rows:
        print("| " + " | ".join(f"{row[k]:.3g}" if isinstance(row[k], float) else str(row[k]) for k in keys) + " |")
    print("\nstep ratios per map:")
    for row in rows:
        print(f"- {row['scan']}: " + ", ".join(f"{k} {v:.3f}" for k, v in row["steps"].items() if v is not None))
    if not args.quick:
        with tempfile.TemporaryDirectory() as tmp:
            sizes = sizes_case(Path(tmp))
        print("\none bark at 1K, 2K and 4K (oak, seed 0): " + ", ".join(f"{k} {v:.3g}" for k, v in sizes.items()))
        rows.append({"sizes": sizes})
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2, default=str))


def cases(args) -> None:
    """The ``--cases`` table (see the module)."""
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for case in CASES:
            rows.append(measure_case(case, args.case_size, Path(tmp), args.save))
            print(f"{case}: done", file=sys.stderr)
    keys = list(rows[0])
    size = args.case_size
    print(
        f"scanned sets of every naming style, {size}² colour -> {2 * size}² tileable, seed 0; longest line px, "
        "output / the input's own repeated 2x2 (! longer)"
    )
    print("| " + " | ".join(keys) + " |")
    print("|" + "---|" * len(keys))
    for row in rows:
        print("| " + " | ".join(f"{row[k]:.3g}" if isinstance(row[k], float) else str(row[k]) for k in keys) + " |")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2, default=str))


if __name__ == "__main__":
    main()
