#!/usr/bin/env python3
"""Synthesis along a flow field (issue 34): does the bark follow the field, and is it as good as
plain synthesis where the field is constant?

    .venv/bin/python benchmarks/bench_flow.py [--quick] [--size 512] [--photos fissured,willow]
        [--mode synth|generate] [--json out.json]

For each of four shared photos with upright fissures (fissured, furrowed, vertical fractures,
willow), one output of ``--size`` square along a field that turns the bark by up to 90°: a
whirl round a knot (the fissures flow round it as a stream round a post, and circle it inside;
its radius 1.5 fissure periods, at least a tenth of the side: a knot smaller than the fissures'
spacing has no fissure to turn) plus a band turned by 45°. Measured:

- the output's local dominant orientation (the structure tensor at the fissure scale: its
  window a fissure period, found from the photo's spectrum) against the photo's own dominant
  direction turned by the field: median and 90th percentile of the angular error, over every
  pixel; the same for plain synthesis (no field) as the baseline the field must beat;
- where the field is constant: outputs along a field of 0° and of 30° everywhere, the
  coherence of each (:func:`barkgen.evaluate.coherence`) (against the photo turned as the field says: the atlas's one copy)
  over plain synthesis's (against the photo), same seed, same run: the ratios;
- seconds of the run along the whirl and of the plain one, in the same process.

``--mode generate`` runs ``barkgen.pipeline.generate`` (label map, texture-by-numbers, material)
instead of the engine alone.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("BARKGEN_SHARED", REPO.parent / "shared"))
PHOTOS = {
    "fissured": "fissured_gray_01.png",
    "furrowed": "furrowed_fine_01.jpg",
    "vertical": "vertical_fractures_01.png",
    "willow": "willow_furrowed_01.jpg",
}


def whirl_and_band(height: int, width: int, radius: float) -> np.ndarray:
    """The field (degrees): a knot of ``radius`` at (0.3 H, 0.3 W) round which upright fissures
    flow as a stream round a post (the deflection of potential flow, faded to 0 by three radii)
    and which they circle inside, plus a band turned by 45° (x + y between 1.35 W and 1.65 W)."""
    rows, cols = np.mgrid[0:height, 0:width].astype(np.float64)
    x, y = cols - 0.3 * width, -(rows - 0.3 * height)
    a = float(radius)
    z = y - 1j * x  # the upward stream turned to run along +x
    r = np.abs(z)
    outside = -np.degrees(np.angle(1 - a * a / np.where(r < a, a, z) ** 2))
    t = np.clip((r - a) / (2 * a), 0.0, 1.0)
    outside *= 1.0 - t * t * (3.0 - 2.0 * t)
    circling = np.mod(np.degrees(np.arctan2(y, x)) + 90.0, 180.0) - 90.0
    field = np.where(r < a, circling, outside)
    band = (cols + rows > 1.35 * width) & (cols + rows < 1.65 * width)
    return np.where(band, 45.0, field).astype(np.float32)


def fissure_period(photo: np.ndarray) -> float:
    """The photo's dominant period across its fissures (px), from the spectrum of its rows."""
    grey = photo.astype(np.float64).mean(axis=2) if photo.ndim == 3 else photo.astype(np.float64)
    rows = grey - grey.mean(axis=1, keepdims=True)
    power = (np.abs(np.fft.rfft(rows, axis=1)) ** 2).mean(axis=0)
    freqs = np.fft.rfftfreq(grey.shape[1])
    usable = (freqs >= 1.0 / 64.0) & (freqs <= 0.25)
    return float(1.0 / freqs[usable][np.argmax(power[usable])])


def orientation(image: np.ndarray, period: float) -> np.ndarray:
    """Each pixel's dominant direction (degrees, counter-clockwise on screen, mod 180): the
    structure tensor of the gradients over a window of one fissure period."""
    import cv2

    grey = image.astype(np.float32).mean(axis=2) if image.ndim == 3 else image.astype(np.float32)
    grey = cv2.GaussianBlur(grey, (0, 0), max(period / 8.0, 0.7))
    gx = cv2.Sobel(grey, cv2.CV_32F, 1, 0)
    gy = -cv2.Sobel(grey, cv2.CV_32F, 0, 1)
    window = max(period / 2.0, 2.0)
    jxx, jyy, jxy = (cv2.GaussianBlur(v, (0, 0), window) for v in (gx * gx, gy * gy, gx * gy))
    across = 0.5 * np.degrees(np.arctan2(2 * jxy, jxx - jyy))
    return np.mod(across + 90.0, 180.0)


def angle_error(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs(np.mod(a - b + 90.0, 180.0) - 90.0)


def dominant(directions: np.ndarray) -> float:
    """The mean axis of directions mod 180 (doubled-angle mean)."""
    doubled = np.radians(2.0 * directions)
    return float(np.mod(np.degrees(np.arctan2(np.sin(doubled).mean(), np.cos(doubled).mean())) / 2.0, 180.0))


def run_case(name: str, size: int, mode: str, seed: int = 0) -> dict:
    from barkgen.evaluate import coherence
    from barkgen.io import read_image
    from barkgen.pipeline import GenerateOptions, generate
    from barkgen.synth import Budget, Canvas, synthesize

    photo = read_image(SHARED / "data" / "bark" / PHOTOS[name])
    period = fissure_period(photo)
    # a knot a fissure can run round: 1.5 fissure periods in radius, at least a tenth of the side
    field = whirl_and_band(size, size, max(0.1 * size, 1.5 * period))

    def make(**fields) -> tuple[np.ndarray, float]:
        t0 = time.perf_counter()
        canvas = Canvas((size, size), **fields)
        if mode == "generate":
            image = generate(photo, GenerateOptions(size=(size, size), seed=seed), canvas=canvas).texture
        else:
            image = synthesize(photo, canvas=canvas, budget=Budget(seed=seed)).image
        return image, time.perf_counter() - t0

    along, along_s = make(flow=field)
    plain, plain_s = make()
    own = dominant(orientation(photo, period))
    wanted = own + field
    error = angle_error(orientation(along, period), wanted)
    plain_error = angle_error(orientation(plain, period), wanted)
    plain_coherence = coherence(plain, photo)
    ratios = {}
    for angle in (0.0, 30.0):
        constant = np.full((size, size), angle, np.float32)
        turned = synthesize(photo, canvas=Canvas((size, size), flow=constant), budget=Budget(seed=seed))
        oriented = turned.orientation
        copy = oriented.atlas(photo)[oriented.margin : oriented.margin + oriented.copy_shape[0]]
        ratios[angle] = coherence(turned.image, copy) / plain_coherence
    return {
        "photo": name,
        "size": size,
        "mode": mode,
        "period px": round(period, 1),
        "photo direction": round(own, 1),
        "median error": float(np.median(error)),
        "p90 error": float(np.percentile(error, 90)),
        "plain median": float(np.median(plain_error)),
        "plain p90": float(np.percentile(plain_error, 90)),
        "coherence ratio 0 deg": ratios[0.0],
        "coherence ratio 30 deg": ratios[30.0],
        "flow s": along_s,
        "plain s": plain_s,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="512 px outputs, two photos")
    parser.add_argument("--size", type=int, default=None)
    parser.add_argument("--photos", default=None, help="comma-separated: " + ",".join(PHOTOS))
    parser.add_argument("--mode", choices=("synth", "generate"), default="synth")
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    if not (SHARED / "data" / "bark").is_dir():
        sys.exit(f"needs the team's shared photos at {SHARED} (set BARKGEN_SHARED)")
    sys.path.insert(0, str(REPO / "src"))
    size = args.size or (512 if args.quick else 1024)
    names = args.photos.split(",") if args.photos else (["fissured", "vertical"] if args.quick else list(PHOTOS))
    rows = [run_case(name, size, args.mode) for name in names]
    columns = list(rows[0])
    print("| " + " | ".join(columns) + " |")
    print("|" + "---|" * len(columns))
    for row in rows:
        print("| " + " | ".join(f"{v:.3g}" if isinstance(v, float) else str(v) for v in row.values()) + " |")
    medians = {k: statistics.median(r[k] for r in rows) for k in ("median error", "p90 error")}
    print(
        f"\nworst median error {max(r['median error'] for r in rows):.1f} deg, worst p90 "
        f"{max(r['p90 error'] for r in rows):.1f} deg (medians over photos: {medians['median error']:.1f}, "
        f"{medians['p90 error']:.1f}); worst coherence ratio "
        f"{max(max(r['coherence ratio 0 deg'], r['coherence ratio 30 deg']) for r in rows):.2f}"
    )
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
