#!/usr/bin/env python3
"""Each scanned bark rendered beside barkgen's set of its photo, in Blender, under one light
(issue 65): the scan's own relief and the one barkgen estimates from the colour alone, seen the
same way, with their tilt histograms.

    .venv/bin/python benchmarks/render_scans.py [--barks oak,pine] [--out docs/images/scan_vs_barkgen.jpg]
        [--width-m 0.5] [--resolution 480 360] [--samples 24] [--sun-elevation 30]
        [--camera-elevation 40] [--camera-distance 0.6] [--keep DIR] [--json out.json]

Needs the team's shared data folder (``$BARKGEN_SHARED``, default ``../shared``: the colour
photos in ``data/bark``, the scans' normal, AO and roughness maps in ``data/bark_maps``) and
Blender (``blender`` on the PATH, or ``--blender``; tested with Debian's 3.4).

Per bark (birch, oak, pine, willow; ``--barks`` a subset, by any part of the name), two sets of
the same real width (``--width-m``, so their depths in metres compare):

- the scan's: a folder staged with the photo as the colour and the scan's maps, read by
  :func:`barkgen.io.read_scanned_set` and made by :func:`barkgen.material.scanned_material` on
  the torus (the scans tile): the scan's normals, AO and roughness, its height the normals
  integrated;
- barkgen's: :func:`barkgen.material.make_material` of the photo alone (defaults, as
  ``barkgen material PHOTO --width-m W`` makes it).

Each is written with its ``NAME_blender.py``, which builds it in Blender (the material, the
2 x 2 plane at the set's real size, displaced by its Displace modifier); a small scene script of
this benchmark, run after it by a second ``--python``, leaves the plane alone in the scene and
renders it with Cycles on the CPU, one Blender at a time, the same camera for both sets
(``--camera-elevation`` degrees up, ``--camera-distance`` metres from the plane's centre, in
front) and the same low sun (``--sun-elevation`` degrees up, from the left and a little behind).
The tilt is each normal's angle from +Z, in degrees: the scan's normal map against barkgen's
``NormalGL``.

Prints a table: per bark, the scan's and barkgen's tilt (median / 90th percentile, degrees),
each set's displacement depth (mm, highest minus deepest point, what the Displace modifier
spans), the depth of each set's relief under 1 cm (mm, 1st to 99th percentile of the height
less its 1 cm Gaussian blur: the scans' broad undulation and a few outlying pixels left out) and
the seconds of the bark's two renders, then the total time. Writes ``--out``: a block per bark, the scan's render left and
barkgen's right, under them the two tilt histograms (0-60 degrees, 2-degree bins, as outlines
on one plot) with the medians, 90th percentiles and depths in the caption.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont
from scipy import ndimage as ndi

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("BARKGEN_SHARED", REPO.parent / "shared"))
sys.path.insert(0, str(REPO / "src"))

from barkgen.io import encode_material, read_image, read_scanned_set, write_bytes_atomic  # noqa: E402
from barkgen.io.blender import blender_script_name  # noqa: E402
from barkgen.material import MaterialOptions, make_material, scanned_material  # noqa: E402

BARKS = ("birch_smooth_lenticels_01", "oak_furrowed_moss_01", "pine_plated_01", "willow_furrowed_01")
#: the tilt histogram's bins, degrees
TILT_BINS = np.arange(0.0, 60.0 + 1e-9, 2.0)
#: the scale (m) under which the height's relief is "fine": its Gaussian blur of this sigma is taken out
FINE_SCALE_M = 0.01
#: the outlines' colours: the scan's, barkgen's
SCAN_COLOUR = (214, 96, 26)
BARKGEN_COLOUR = (38, 98, 196)

#: run by Blender after the set's NAME_blender.py has made material and plane NAME: the scene
#: emptied of everything else, one camera and one sun as BARKGEN_RENDER (JSON) says, a Cycles render
SCENE_SCRIPT = '''"""The render of one material set's plane for benchmarks/render_scans.py."""
import json
import math
import os

import bpy
from mathutils import Vector

config = json.loads(os.environ["BARKGEN_RENDER"])
scene = bpy.context.scene
plane = bpy.data.objects[config["name"]]
for obj in list(scene.objects):
    if obj is not plane:
        bpy.data.objects.remove(obj, do_unlink=True)
target = plane.location.copy()

camera = bpy.data.objects.new("render_camera", bpy.data.cameras.new("render_camera"))
camera.data.lens = config["lens_mm"]
up = math.radians(config["camera_elevation"])
camera.location = target + Vector((0.0, -math.cos(up), math.sin(up))) * config["camera_distance_m"]
camera.rotation_euler = (target - camera.location).to_track_quat("-Z", "Y").to_euler()

sun = bpy.data.objects.new("render_sun", bpy.data.lights.new("render_sun", "SUN"))
sun.data.energy = config["sun_energy"]
sun.data.angle = math.radians(config["sun_angle"])
up, round_ = math.radians(config["sun_elevation"]), math.radians(config["sun_azimuth"])
towards_sun = Vector((math.cos(up) * math.cos(round_), math.cos(up) * math.sin(round_), math.sin(up)))
sun.rotation_euler = (-towards_sun).to_track_quat("-Z", "Y").to_euler()

world = bpy.data.worlds.new("render_world")
world.color = config["ambient"]
for extra in (camera, sun):
    scene.collection.objects.link(extra)
scene.camera, scene.world = camera, world
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = config["samples"]
scene.cycles.use_denoising = False
scene.render.resolution_x, scene.render.resolution_y = config["resolution"]
scene.render.resolution_percentage = 100
scene.render.image_settings.file_format = "PNG"
scene.render.image_settings.color_mode = "RGB"
scene.render.filepath = config["out"]
bpy.ops.render.render(write_still=True)
print("BARKGEN-RENDERED " + config["out"])
'''


def pick_barks(text: str | None) -> list[str]:
    if not text:
        return list(BARKS)
    picked = []
    for part in (p.strip() for p in text.split(",") if p.strip()):
        hits = [b for b in BARKS if part in b]
        if len(hits) != 1:
            raise SystemExit(f"--barks: {part!r} names {len(hits)} of {', '.join(BARKS)}")
        picked.append(hits[0])
    return picked


def write_set(material, folder: Path, name: str, **metadata) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    for file, data in encode_material(material, name, **metadata).items():
        write_bytes_atomic(folder / file, data)


def make_sets(bark: str, work: Path, width_m: float) -> dict:
    """The scan's set and barkgen's set of one bark, written under ``work``; their normals and
    depths."""
    photo = SHARED / "data" / "bark" / f"{bark}.jpg"
    staged = work / "staged" / bark
    staged.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(photo, staged / f"{bark}_color.jpg")
    for kind in ("normal", "ao", "roughness"):
        shutil.copyfile(SHARED / "data" / "bark_maps" / f"{bark}_{kind}.jpg", staged / f"{bark}_{kind}.jpg")
    scan = read_scanned_set(staged)
    assert scan.normals is not None, f"{bark}: the scan's normal map was not recognised"
    scanned = scanned_material(scan, wrap=(True, True)).with_width_m(width_m)
    ours = make_material(read_image(photo), MaterialOptions(width_m=width_m))
    sets = {}
    for key, material in (("scan", scanned), ("barkgen", ours)):
        name = f"{bark}_{key}"
        write_set(material, work / name, name, source_photo=photo.name)
        sets[key] = {
            "name": name,
            "folder": work / name,
            "normals": material.normals,
            "depth_mm": 1000.0 * material.physical_size()["displacement_depth_m"],
            "fine_mm": fine_relief_mm(material),
        }
    return sets


def fine_relief_mm(material) -> float:
    """The range (1st to 99th percentile, mm) of a set's height less its Gaussian blur of
    :data:`FINE_SCALE_M`: the depth of its relief under a centimetre, not its broad undulation
    nor a few outlying pixels."""
    height_mm = material.height.astype(np.float64) * material.pixel_size_m * 1000.0
    fine = height_mm - ndi.gaussian_filter(height_mm, FINE_SCALE_M / material.pixel_size_m, mode="wrap")
    return float(np.percentile(fine, 99) - np.percentile(fine, 1))


def render_set(blender: str, entry: dict, scene_script: Path, out: Path, args) -> float:
    """Blender on the set's NAME_blender.py, then the scene script; the seconds it took."""
    config = {
        "name": entry["name"],
        "out": str(out.resolve()),
        "resolution": list(args.resolution),
        "samples": args.samples,
        "lens_mm": 50.0,
        "camera_elevation": args.camera_elevation,
        "camera_distance_m": args.camera_distance,
        "sun_elevation": args.sun_elevation,
        "sun_azimuth": 160.0,
        "sun_energy": args.sun_energy,
        "sun_angle": 1.0,
        "ambient": [0.04, 0.045, 0.05],
    }
    setup = entry["folder"] / blender_script_name(entry["name"])
    command = [blender, "-b", "--factory-startup", "--python-exit-code", "1"]
    command += ["--python", str(setup), "--python", str(scene_script)]
    start = time.perf_counter()
    done = subprocess.run(
        command, capture_output=True, text=True, env={**os.environ, "BARKGEN_RENDER": json.dumps(config)}
    )
    if done.returncode != 0 or not out.is_file():
        raise SystemExit(f"Blender failed on {setup}:\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}")
    return time.perf_counter() - start


def tilt_degrees(normals: np.ndarray) -> np.ndarray:
    """Each normal's angle from +Z, degrees."""
    return np.degrees(np.arccos(np.clip(normals[..., 2], -1.0, 1.0)))


def tilt_figures(normals: np.ndarray) -> dict:
    tilt = tilt_degrees(normals).ravel()
    counts, _ = np.histogram(tilt, bins=TILT_BINS)
    return {
        "median": float(np.median(tilt)),
        "p90": float(np.percentile(tilt, 90)),
        "beyond": float((tilt > TILT_BINS[-1]).mean()),
        "percent": 100.0 * counts / tilt.size,
    }


def font(size: int) -> ImageFont.FreeTypeFont:
    for path in ("/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",):
        if Path(path).is_file():
            return ImageFont.truetype(path, size)
    return ImageFont.load_default(size=size)


def histogram_panel(scan: dict, ours: dict, size: tuple[int, int]) -> Image.Image:
    """The two tilt histograms as outlines on one plot, axes in degrees and percent of pixels,
    the figures in a caption under it."""
    width, height = size
    panel = Image.new("RGB", size, "white")
    draw = ImageDraw.Draw(panel)
    small, text = font(13), font(14)
    left, right, top, bottom = 58, 16, 12, height - 62
    top_percent = max(float(scan["percent"].max()), float(ours["percent"].max()))
    step = 2.0 if top_percent <= 12 else 5.0
    y_max = step * np.ceil(top_percent / step + 0.05)

    def xy(degrees: float, percent: float) -> tuple[float, float]:
        x = left + (right_x - left) * degrees / TILT_BINS[-1]
        return x, bottom - (bottom - top) * percent / y_max

    right_x = width - right
    for tick in np.arange(0.0, y_max + 1e-9, step):
        _, y = xy(0, tick)
        draw.line([(left, y), (right_x, y)], fill=(232, 232, 232))
        draw.text((left - 6, y), f"{tick:g}%", fill="black", font=small, anchor="rm")
    for tick in range(0, int(TILT_BINS[-1]) + 1, 10):
        x, _ = xy(tick, 0)
        draw.line([(x, bottom), (x, bottom + 4)], fill="black")
        draw.text((x, bottom + 6), f"{tick}°", fill="black", font=small, anchor="mt")
    draw.line([(left, top), (left, bottom), (right_x, bottom)], fill="black")
    draw.text(
        (right_x - 4, top + 2), "tilt from +Z; share of pixels a 2° bin", fill=(90, 90, 90), font=small, anchor="rt"
    )
    for figures, colour in ((scan, SCAN_COLOUR), (ours, BARKGEN_COLOUR)):
        points = []
        for i, percent in enumerate(figures["percent"]):
            points += [xy(TILT_BINS[i], percent), xy(TILT_BINS[i + 1], percent)]
        draw.line([xy(0, 0), *points, xy(TILT_BINS[-1], 0)], fill=colour, width=3)
    for row, (label, figures, colour) in enumerate(
        (("scan's set", scan, SCAN_COLOUR), ("barkgen's set", ours, BARKGEN_COLOUR))
    ):
        y = bottom + 26 + 17 * row
        draw.line([(left, y), (left + 22, y)], fill=colour, width=3)
        draw.text(
            (left + 30, y),
            f"{label}: tilt median {figures['median']:.1f}°, 90th percentile {figures['p90']:.1f}°, "
            f"{100 * figures['beyond']:.1f}% beyond 60°; relief {figures['depth_mm']:.1f} mm deep",
            fill="black",
            font=text,
            anchor="lm",
        )
    return panel


def compose(rows: list[dict], renders: Path, out: Path, resolution: tuple[int, int]) -> None:
    """A block per bark: its name, the two renders side by side, the histograms under them."""
    width, height = resolution
    gap, title_h, plot_h = 8, 30, 230
    page_w = 2 * width + gap
    block_h = title_h + height + plot_h
    head_h = 34
    page = Image.new("RGB", (page_w, head_h + len(rows) * block_h), "white")
    draw = ImageDraw.Draw(page)
    draw.text(
        (width // 2, head_h // 2),
        "scan's own set (its normals, AO, roughness)",
        fill="black",
        font=font(16),
        anchor="mm",
    )
    draw.text(
        (width + gap + width // 2, head_h // 2),
        "barkgen's set from the photo alone",
        fill="black",
        font=font(16),
        anchor="mm",
    )
    for i, row in enumerate(rows):
        y = head_h + i * block_h
        draw.rectangle([(0, y), (page_w, y + title_h - 4)], fill=(238, 238, 238))
        draw.text((8, y + (title_h - 4) // 2), row["bark"], fill="black", font=font(16), anchor="lm")
        for j, key in enumerate(("scan", "barkgen")):
            page.paste(
                Image.open(renders / f"{row['bark']}_{key}.png").convert("RGB"), (j * (width + gap), y + title_h)
            )
        page.paste(histogram_panel(row["scan"], row["barkgen"], (page_w, plot_h)), (0, y + title_h + height))
    out.parent.mkdir(parents=True, exist_ok=True)
    page.save(out, quality=84, optimize=True, progressive=True)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--barks", help="comma-separated subset (any part of a name: oak,pine)")
    parser.add_argument("--out", type=Path, default=REPO / "docs" / "images" / "scan_vs_barkgen.jpg")
    parser.add_argument("--width-m", type=float, default=0.5, help="both sets' real width, metres")
    parser.add_argument("--resolution", type=int, nargs=2, default=(480, 360), metavar=("W", "H"))
    parser.add_argument("--samples", type=int, default=24)
    parser.add_argument("--sun-elevation", type=float, default=30.0, help="degrees above the plane")
    parser.add_argument("--sun-energy", type=float, default=4.5, help="W/m^2")
    parser.add_argument("--camera-elevation", type=float, default=40.0, help="degrees above the plane")
    parser.add_argument("--camera-distance", type=float, default=0.6, help="metres from the plane's centre")
    parser.add_argument("--blender", default=shutil.which("blender"), help="Blender's executable")
    parser.add_argument("--keep", type=Path, help="keep the sets and renders in this folder")
    parser.add_argument("--json", type=Path, help="write the table's figures here")
    args = parser.parse_args(argv)
    if not args.blender:
        raise SystemExit("needs Blender: install it (Debian: apt-get install blender) or give --blender")
    if not (SHARED / "data" / "bark_maps").is_dir():
        raise SystemExit(f"needs the shared data folder: {SHARED}/data/bark_maps is missing (set BARKGEN_SHARED)")
    barks = pick_barks(args.barks)
    start = time.perf_counter()
    work = args.keep or Path(tempfile.mkdtemp(prefix="render_scans_"))
    work.mkdir(parents=True, exist_ok=True)
    scene_script = work / "render_scene.py"
    scene_script.write_text(SCENE_SCRIPT)
    renders = work / "renders"
    renders.mkdir(exist_ok=True)
    rows = []
    try:
        for bark in barks:
            t0 = time.perf_counter()
            sets = make_sets(bark, work, args.width_m)
            row = {"bark": bark, "sets_s": time.perf_counter() - t0, "render_s": 0.0}
            for key, entry in sets.items():
                row["render_s"] += render_set(args.blender, entry, scene_script, renders / f"{bark}_{key}.png", args)
                row[key] = {
                    **tilt_figures(entry["normals"]),
                    "depth_mm": entry["depth_mm"],
                    "fine_mm": entry["fine_mm"],
                }
            rows.append(row)
            print(f"{bark}: sets {row['sets_s']:.1f} s, renders {row['render_s']:.1f} s", file=sys.stderr, flush=True)
        compose(rows, renders, args.out, tuple(args.resolution))
    finally:
        if args.keep is None:
            shutil.rmtree(work, ignore_errors=True)
    total = time.perf_counter() - start
    print(
        f"\n{len(barks)} barks, both sets {args.width_m:g} m wide; renders {args.resolution[0]}x{args.resolution[1]}, "
        f"{args.samples} samples, sun {args.sun_elevation:g} deg up; tilt in degrees (median / 90th percentile)"
    )
    print(
        "| bark | scan tilt | barkgen tilt | scan depth, mm | barkgen depth, mm "
        "| relief under 1 cm, mm: scan / barkgen | renders, s |"
    )
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        s, b = r["scan"], r["barkgen"]
        print(
            f"| {r['bark']} | {s['median']:.1f} / {s['p90']:.1f} | {b['median']:.1f} / {b['p90']:.1f} "
            f"| {s['depth_mm']:.1f} | {b['depth_mm']:.1f} | {s['fine_mm']:.1f} / {b['fine_mm']:.1f} "
            f"| {r['render_s']:.0f} |"
        )
    size_kb = args.out.stat().st_size / 1024
    print(f"\nwrote {args.out} ({size_kb:.0f} KB) in {total:.0f} s")
    if args.json:
        keep = ("median", "p90", "beyond", "depth_mm", "fine_mm")
        figures = [
            {
                "bark": r["bark"],
                "sets_s": r["sets_s"],
                "render_s": r["render_s"],
                **{key: {k: r[key][k] for k in keep} for key in ("scan", "barkgen")},
            }
            for r in rows
        ]
        args.json.write_text(json.dumps({"rows": figures, "total_s": total}, indent=2) + "\n")


if __name__ == "__main__":
    main()
