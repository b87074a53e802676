#!/usr/bin/env python3
"""Material maps against scanned truth, shading removal, and speed, in one run.

    .venv/bin/python benchmarks/bench_material.py [--runs 3] [--previews DIR] [--json out.json]
        [--skip-truth] [--skip-shading] [--skip-speed]

Truth (``../shared/data/bark_maps``: scanned normal and AO of four photos, OpenGL), of the
normal map :func:`make_material` estimates from the colour photo alone (its broad light taken
out first, as the product does):

- the relief's depth: the median and 90th percentile of the normals' tilt over the scan's
  (targets 0.8-1.25x and 0.7-1.4x);
- its direction: the uncentred correlation of the slope vectors with the scan's (target: at
  least the Sobel of the luminance's, blur 2 px), and the mean angle to the scan's normals
  (target: at most the same Sobel's with its strength tilt-matched leave-one-out);
- the mean angular error against a flat normal map (0, 0, 1), the usual Sobel-of-luminance
  normal with one fixed blur and strength chosen leave-one-out on the mean angle (the best on
  the other three scans), and, as an oracle, that Sobel tuned per image *on the truth*.

The height's weights and strength were fitted on these maps, so the figures here are
leave-one-out: refitted on the other three photos (least squares of the height's gradient
against the scans' slopes, each scan weighed by its slopes' spread, then the strength whose
tilts match the scans', :func:`tilt_scale`). AO: Pearson correlation with the scanned AO (target
>= 0.5) of the AO of the leave-one-out height plus the photo's cavities, their weight and scale
picked on the other three photos too; also shown, the height's AO alone. Also shown: the
ceiling, i.e. the error of the scan's own height (its normals integrated, Frankot-Chellappa),
which no height field can beat, and the correlation of that height's AO.

Shading (every photo of ``../shared/data/bark``): correlation of luminance with the estimated
``N·L`` before (photo) and after (albedo) shading removal (target: at least halved), and
the albedo's RMS gradient of lightness over the photo's (the square root of
:func:`barkgen.evaluate.sharpness_ratio`, a ratio of gradient energies; target >= 0.85).

Speed: ``make_material`` on a 1024^2 photo (target <= 10 s) and ``render_trunk`` at 1024^2
(target <= 5 s), medians over ``--runs``, next to the Sobel normal map in the same process.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np
from scipy import ndimage as ndi

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("BARKGEN_SHARED", REPO.parent / "shared"))
sys.path.insert(0, str(REPO / "src"))

from barkgen._shared.checks import check_image  # noqa: E402
from barkgen.io import read_image, write_png  # noqa: E402
from barkgen.labels import color_regions  # noqa: E402
from barkgen.labels.regions import to_codes  # noqa: E402
from barkgen.material import (  # noqa: E402
    Boundary,  # noqa: E402
    HeightConfig,
    MaterialOptions,
    ambient_occlusion,
    decode_normals,
    equalize_light,
    make_material,
    normal_map,
    photo_cavities,
    shading,
)
from barkgen.material.height import height_features, luminance  # noqa: E402
from barkgen.material.maps import CAVITY_SCALE, CAVITY_WEIGHT  # noqa: E402
from barkgen.render import render_trunk  # noqa: E402

SCANNED = ("birch_smooth_lenticels_01", "oak_furrowed_moss_01", "pine_plated_01", "willow_furrowed_01")
#: the cues whose weights are fitted: the defaults' scales, every weight refitted
CUES = HeightConfig()


def angular_error(normals: np.ndarray, truth: np.ndarray) -> float:
    dot = np.clip((normals * truth).sum(axis=2), -1.0, 1.0)
    return float(np.degrees(np.arccos(dot)).mean())


def flat_error(truth: np.ndarray) -> float:
    return angular_error(
        np.dstack([np.zeros(truth.shape[:2]), np.zeros(truth.shape[:2]), np.ones(truth.shape[:2])]), truth
    )


def frankot_chellappa(normals: np.ndarray) -> np.ndarray:
    """The least-squares height (pixels) of a normal map (OpenGL), periodic."""
    p = -normals[..., 0] / normals[..., 2]  # dh/dx
    q = normals[..., 1] / normals[..., 2]  # dh/drow
    h, w = p.shape
    wx = np.fft.fftfreq(w)[None, :] * 2 * np.pi
    wy = np.fft.fftfreq(h)[:, None] * 2 * np.pi
    den = wx**2 + wy**2
    den[0, 0] = 1.0
    spectrum = (-1j * wx * np.fft.fft2(p) - 1j * wy * np.fft.fft2(q)) / den
    spectrum[0, 0] = 0.0
    return np.real(np.fft.ifft2(spectrum))


def load_case(name: str, equalize: float = 1.0) -> dict:
    """A scan's photo, truth (normals, AO) and the height's cues of its photo with ``equalize``
    of its broad light taken out (as :func:`make_material` sees it)."""
    photo = check_image(read_image(SHARED / "data" / "bark" / f"{name}.jpg"))
    truth = decode_normals(read_image(SHARED / "data" / "bark_maps" / f"{name}_normal.jpg"))
    ao = read_image(SHARED / "data" / "bark_maps" / f"{name}_ao.jpg").astype(np.float32)
    ao = (ao[..., 0] if ao.ndim == 3 else ao) / 255.0
    seen, _ = equalize_light(photo, equalize)
    codes, _ = to_codes(color_regions(seen, 3, seed=0))
    features = [f for _, f in height_features(seen, codes, CUES, boundary=Boundary(False))]
    return {
        "name": name,
        "photo": photo,
        "truth": truth,
        "ao": ao,
        "codes": codes,
        "features": features,
        "equalize": equalize,
    }


def slope_magnitude(normals: np.ndarray) -> np.ndarray:
    """|grad h| of a normal map: the tangent of its tilt."""
    return np.hypot(normals[..., 0], normals[..., 1]) / np.maximum(normals[..., 2], 1e-6)


def tilt_degrees(normals: np.ndarray) -> np.ndarray:
    return np.degrees(np.arccos(np.clip(normals[..., 2], -1.0, 1.0)))


#: the tilt quantiles (percent) whose ratios to the scans' the relief strength matches
TILT_QUANTILES = (50, 90)


def tilt_scale(normals: list[np.ndarray], truths: list[np.ndarray]) -> float:
    """The factor on the slopes of ``normals`` that best matches the tilt distribution of
    ``truths``: the geometric mean, over the pairs and :data:`TILT_QUANTILES`, of the ratio of
    the truth's slope quantile to the estimate's (a tilt is the arctangent of the slope, so
    matching slopes matches tilts)."""
    logs = [
        np.log(np.percentile(slope_magnitude(t), q) / max(np.percentile(slope_magnitude(n), q), 1e-9))
        for n, t in zip(normals, truths)
        for q in TILT_QUANTILES
    ]
    return float(np.exp(np.mean(logs)))


def material_of(case: dict, config: HeightConfig):
    """``make_material`` of the case's photo, the product's path (its equalisation, its label map)."""
    return make_material(
        case["photo"],
        MaterialOptions(height=config, exemplar_wrap="no", equalize_light=case["equalize"]),
        label_map=case["codes"],
    )


def fit_config(cases: list[dict]) -> HeightConfig:
    """Band and label weights by least squares of the height's gradient against the scans'
    slopes (on ``cases`` only), then the strength whose tilt distribution matches the scans'
    (:func:`tilt_scale` of the product's normals; before issue 65 it was the strength that
    minimised the mean angular error, which rewards a timid relief wherever the direction is
    uncertain)."""
    rows, targets = [], []
    for case in cases:
        grads = [np.gradient(f) for f in case["features"]]  # (d/drow, d/dx)
        rows.append(np.stack([np.concatenate([gx.ravel(), gy.ravel()]) for gy, gx in grads], axis=1))
        t = case["truth"]
        target = np.concatenate([(-t[..., 0] / t[..., 2]).ravel(), (t[..., 1] / t[..., 2]).ravel()])
        # each scan weighed by its own slopes' spread: a deep scan whose slopes no cue explains
        # (willow) does not outweigh a shallower one whose slopes they do
        spread = float(np.sqrt(np.mean(target**2)))
        rows[-1] = rows[-1] / spread
        targets.append(target / spread)
    weights = [float(w) for w in np.linalg.lstsq(np.concatenate(rows), np.concatenate(targets), rcond=None)[0]]
    n_bands, n_energy = len(CUES.bands), len(CUES.energy_bands)
    config = HeightConfig(
        bands=tuple((s, w) for (s, _), w in zip(CUES.bands, weights[:n_bands])),
        energy_bands=tuple((s, w) for (s, _), w in zip(CUES.energy_bands, weights[n_bands : n_bands + n_energy])),
        label_weight=weights[-1],
        strength=1.0,
    )
    # (the height's depth is linear in the strength)
    scale = tilt_scale([material_of(c, config).normals for c in cases], [c["truth"] for c in cases])
    return dataclasses.replace(config, strength=scale)


def slope_correlation(normals: np.ndarray, truth: np.ndarray) -> float:
    """Uncentred correlation of two normal maps' slope vectors over all pixels (1: the same
    directions and proportions, whatever the scale)."""
    a = np.stack([normals[..., 0] / normals[..., 2], normals[..., 1] / normals[..., 2]])
    b = np.stack([truth[..., 0] / truth[..., 2], truth[..., 1] / truth[..., 2]])
    return float((a * b).sum() / np.sqrt((a * a).sum() * (b * b).sum()))


#: the Sobel peer's grid: blur (px) of the luminance, and the strength its slopes are scaled by
SOBEL_BLURS = (0.0, 1.0, 2.0, 4.0)
SOBEL_STRENGTHS = np.geomspace(0.002, 1.0, 28)


def sobel_errors(case: dict) -> np.ndarray:
    """The peer baseline (AwesomeBump's and NormalMap-Online's default: the luminance as height,
    blurred and scaled): its mean angular error for every (blur, strength) of the grid."""
    lum = luminance(case["photo"]).astype(np.float64) * 255.0
    errors = np.empty((len(SOBEL_BLURS), len(SOBEL_STRENGTHS)))
    for i, blur in enumerate(SOBEL_BLURS):
        height = ndi.gaussian_filter(lum, blur) if blur else lum
        for j, s in enumerate(SOBEL_STRENGTHS):
            errors[i, j] = angular_error(normal_map(height * s), case["truth"])
    return errors


#: the grid the AO's photo cavities (weight, scale) are fitted on, leave-one-out
CAVITY_GRID = [(w, sc) for sc in (16, 32, 64) for w in (0.0, 0.25, 0.5, 1.0, 2.0, 4.0)]


def ao_correlation(ao_height: np.ndarray, case: dict, weight: float, scale: float) -> float:
    cavities = photo_cavities(ao_height, luminance(case["photo"]), weight=weight, scale=scale)
    ao = np.clip(ao_height + cavities, 0.0, 1.0)
    return float(np.corrcoef(ao.ravel(), case["ao"].ravel())[0, 1])


#: the Sobel peer's blur (px) where its strength is tilt-matched (the blur the angle grid picks
#: leave-one-out on every scan)
SOBEL_TILT_BLUR = 2.0


def sobel_normals(case: dict, strength: float) -> np.ndarray:
    """The Sobel peer's normals: the luminance (0-255) blurred, scaled, as height."""
    lum = luminance(case["photo"]).astype(np.float64) * 255.0
    return normal_map(ndi.gaussian_filter(lum, SOBEL_TILT_BLUR) * strength)


def tilt_row(normals: np.ndarray, truth: np.ndarray, prefix: str) -> dict:
    """The tilt figures of an estimate: median and 90th percentile over the scan's, slope
    correlation, mean angle."""
    tilt, scan = tilt_degrees(normals), tilt_degrees(truth)
    return {
        f"{prefix}_tilt50": float(np.median(tilt)),
        f"{prefix}_tilt90": float(np.percentile(tilt, 90)),
        f"{prefix}_tilt50_ratio": float(np.median(tilt) / np.median(scan)),
        f"{prefix}_tilt90_ratio": float(np.percentile(tilt, 90) / np.percentile(scan, 90)),
        f"{prefix}_corr": slope_correlation(normals, truth),
        f"{prefix}_angle": angular_error(normals, truth),
    }


def truth_table() -> list[dict]:
    cases = [load_case(n) for n in SCANNED]
    sobel = [sobel_errors(case) / flat_error(case["truth"]) for case in cases]
    sobel_unit = [sobel_normals(case, 1.0) for case in cases]
    rows = []
    for i, case in enumerate(cases):
        config = fit_config([c for j, c in enumerate(cases) if j != i])
        # the product's path: make_material with the leave-one-out weights (its light fitted
        # jointly with the height, the shading's height joined as far as they agree)
        material = material_of(case, config)
        # the peer with its strength matched the same way, leave-one-out
        sobel_scale = tilt_scale(
            [n for j, n in enumerate(sobel_unit) if j != i], [c["truth"] for j, c in enumerate(cases) if j != i]
        )
        case["ao_height"] = ambient_occlusion(material.height)
        ours = angular_error(material.normals, case["truth"])
        integrated = frankot_chellappa(case["truth"])
        # the fixed-strength peer: its (blur, strength) the best on the other three scans
        others = np.mean([r for j, r in enumerate(sobel) if j != i], axis=0)
        cell = np.unravel_index(int(np.argmin(others)), others.shape)
        scan_tilt = tilt_degrees(case["truth"])
        row = {
            "photo": case["name"],
            "flat": flat_error(case["truth"]),
            "barkgen_loo": ours,
            "scan_tilt50": float(np.median(scan_tilt)),
            "scan_tilt90": float(np.percentile(scan_tilt, 90)),
            **tilt_row(material.normals, case["truth"], "ours"),
            **tilt_row(sobel_normals(case, sobel_scale), case["truth"], "sobel"),
            "depth_px": material.depth,
            "sobel_tuned": float(sobel[i].min() * flat_error(case["truth"])),
            "sobel_loo": float(sobel[i][cell] * flat_error(case["truth"])),
            "sobel_loo_setting": [SOBEL_BLURS[cell[0]], float(SOBEL_STRENGTHS[cell[1]])],
            "light": [material.light.azimuth, material.light.elevation, material.light.correlation],
            "ceiling": angular_error(normal_map(integrated, boundary=Boundary(True)), case["truth"]),
            "ao_corr_height": float(np.corrcoef(case["ao_height"].ravel(), case["ao"].ravel())[0, 1]),
            "ao_corr_ceiling": float(
                np.corrcoef(
                    ambient_occlusion(integrated.astype(np.float32), boundary=Boundary(True)).ravel(),
                    case["ao"].ravel(),
                )[0, 1]
            ),
            "loo_config": dataclasses.asdict(config),
        }
        row["ratio"] = row["barkgen_loo"] / row["flat"]
        rows.append(row)
    # the AO's photo cavities: (weight, scale) picked on the other three photos' AO
    grid = {cell: [ao_correlation(c["ao_height"], c, *cell) for c in cases] for cell in CAVITY_GRID}
    for i, (case, row) in enumerate(zip(cases, rows)):
        pick = max(CAVITY_GRID, key=lambda cell: np.mean([r for j, r in enumerate(grid[cell]) if j != i]))
        row["ao_corr"], row["ao_cavities_loo"] = grid[pick][i], list(pick)
        print(
            f"  {case['name']:28s} flat {row['flat']:.1f} barkgen(LOO) {row['barkgen_loo']:.1f} "
            f"({row['ratio']:.2f}x) sobel {row['sobel_loo']:.1f} (tuned {row['sobel_tuned']:.1f}) ceiling {row['ceiling']:.1f} "
            f"AO r {row['ao_corr']:.2f} (height alone {row['ao_corr_height']:.2f}, cavities {pick})",
            file=sys.stderr,
            flush=True,
        )
    print(
        f"  AO cavities fitted on all four: {max(CAVITY_GRID, key=lambda cell: np.mean(grid[cell]))} "
        f"(defaults: {CAVITY_WEIGHT}, {CAVITY_SCALE})",
        file=sys.stderr,
        flush=True,
    )
    return rows


def shading_table(previews: Path | None) -> list[dict]:
    from barkgen.evaluate import sharpness_ratio

    rows = []
    for path in sorted((SHARED / "data" / "bark").glob("*.*")):
        if path.suffix.lower() not in (".jpg", ".png"):
            continue
        photo = check_image(read_image(path))
        material = make_material(photo)
        shade = shading(material.normals, material.light)
        lum_photo, lum_albedo = luminance(photo).ravel(), luminance(material.color).ravel()
        row = {
            "photo": path.stem,
            "light": [material.light.azimuth, material.light.elevation],
            "strength": material.shading_strength,
            "corr_photo": float(np.corrcoef(lum_photo, shade.ravel())[0, 1]),
            "corr_albedo": float(np.corrcoef(lum_albedo, shade.ravel())[0, 1]),
            "sharpness": float(np.sqrt(sharpness_ratio(material.color, photo))),
        }
        rows.append(row)
        print(
            f"  {path.stem:28s} light {row['light'][0]:.0f},{row['light'][1]:.0f} strength "
            f"{row['strength']:.2f} corr photo {row['corr_photo']:+.3f} albedo {row['corr_albedo']:+.3f} "
            f"sharpness {row['sharpness']:.3f}",
            file=sys.stderr,
            flush=True,
        )
        if previews is not None:
            write_png(previews / f"{path.stem}_trunk.png", render_trunk(material, (768, 768)))
    return rows


def speed(runs: int) -> dict:
    photo = read_image(SHARED / "data" / "bark" / "oak_furrowed_moss_01.jpg")
    make_material(photo[:128, :128])  # numba cache
    material_t, render_t, sobel_t = [], [], []
    material = None
    for _ in range(runs):
        t = time.perf_counter()
        material = make_material(photo)
        material_t.append(time.perf_counter() - t)
        t = time.perf_counter()
        normal_map(ndi.gaussian_filter(luminance(check_image(photo)), 1.0) * 40.0)
        sobel_t.append(time.perf_counter() - t)
    render_trunk(material, (64, 64))
    for _ in range(runs):
        t = time.perf_counter()
        render_trunk(material, (1024, 1024))
        render_t.append(time.perf_counter() - t)
    return {
        "material": statistics.median(material_t),
        "sobel_normal": statistics.median(sobel_t),
        "preview": statistics.median(render_t),
        "runs": runs,
        "size": list(photo.shape[:2]),
    }


def fit_all() -> HeightConfig:
    """The weights fitted on all four scans: how the defaults were made (not a figure)."""
    return fit_config([load_case(n) for n in SCANNED])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--previews", type=Path, default=None, help="write a trunk preview per photo here")
    ap.add_argument("--json", default=None)
    ap.add_argument("--skip-truth", action="store_true")
    ap.add_argument("--skip-shading", action="store_true")
    ap.add_argument("--skip-speed", action="store_true")
    ap.add_argument("--fit", action="store_true", help="print the weights fitted on all four scans and stop")
    args = ap.parse_args()
    if args.fit:
        print(fit_all())
        return 0
    out: dict = {}
    if args.previews is not None:
        args.previews.mkdir(parents=True, exist_ok=True)
    if not args.skip_truth:
        rows = out["truth"] = truth_table()
        print("\nRelief against scanned truth (leave-one-out): tilt in degrees, its ratio to the scan's")
        print(
            f"{'photo':28s} {'scan 50/90':>11s} {'barkgen 50/90':>14s} {'ratio':>11s} "
            f"{'corr':>5s} {'sobel':>6s} {'angle':>6s} {'sobel~':>6s} {'flat':>5s} {'depth':>6s}"
        )
        for r in rows:
            print(
                f"{r['photo']:28s} {r['scan_tilt50']:5.1f}/{r['scan_tilt90']:<5.1f} "
                f"{r['ours_tilt50']:7.1f}/{r['ours_tilt90']:<6.1f} "
                f"{r['ours_tilt50_ratio']:5.2f}/{r['ours_tilt90_ratio']:<5.2f} "
                f"{r['ours_corr']:5.3f} {r['sobel_corr']:6.3f} "
                f"{r['ours_angle']:6.1f} {r['sobel_angle']:6.1f} {r['flat']:5.1f} {r['depth_px']:6.1f}"
            )
        print(
            "targets: tilt ratio 0.8-1.25 (median) and 0.7-1.4 (90th percentile); corr (uncentred slope "
            "correlation) >= sobel's; angle <= sobel~'s (the Sobel of the luminance, blur "
            f"{SOBEL_TILT_BLUR:g} px, its strength tilt-matched leave-one-out); depth = displacement depth in px"
        )
        print("\nNormals and AO from the photo alone vs scanned maps (leave-one-out; degrees)")
        print(
            f"{'photo':28s} {'flat':>6s} {'sobel':>6s} {'sobel*':>7s} {'barkgen':>8s} {'ratio':>6s} {'ceiling':>8s} "
            f"{'AO r':>6s} {'height':>7s} {'ceiling':>8s}"
        )
        for r in rows:
            print(
                f"{r['photo']:28s} {r['flat']:6.1f} {r['sobel_loo']:6.1f} {r['sobel_tuned']:7.1f} {r['barkgen_loo']:8.1f} "
                f"{r['ratio']:6.2f} {r['ceiling']:8.1f} {r['ao_corr']:6.2f} {r['ao_corr_height']:7.2f} "
                f"{r['ao_corr_ceiling']:8.2f}"
            )
        print(
            "sobel = its blur and strength the mean-angle best on the other three scans (leave-one-out), "
            "sobel* = tuned on this scan's truth; ceiling = the scan's own integrated height (its normals, "
            "its AO); AO r: with the photo's cavities (weight and scale picked leave-one-out), height: the "
            "height's AO alone"
        )
    if not args.skip_shading:
        rows = out["shading"] = shading_table(args.previews)
        print("\nShading removal (correlation of luminance with the estimated N·L)")
        print(f"{'photo':28s} {'light':>9s} {'g':>5s} {'photo':>7s} {'albedo':>7s} {'halved':>6s} {'sharp':>6s}")
        for r in rows:
            halved = abs(r["corr_albedo"]) <= 0.5 * abs(r["corr_photo"])
            print(
                f"{r['photo']:28s} {r['light'][0]:4.0f},{r['light'][1]:<4.0f} {r['strength']:5.2f} "
                f"{r['corr_photo']:+7.3f} {r['corr_albedo']:+7.3f} {'yes' if halved else 'NO':>6s} "
                f"{r['sharpness']:6.3f}"
            )
        print("targets: |albedo| <= 0.5 |photo|, sharpness >= 0.85")
    if not args.skip_speed:
        s = out["speed"] = speed(args.runs)
        print(f"\nSpeed ({s['size'][1]}x{s['size'][0]} photo, medians of {s['runs']})")
        print(
            f"make_material   {s['material']:6.2f} s   (target <= 10 s; Sobel normal alone {s['sobel_normal']:.3f} s)"
        )
        print(f"render_trunk    {s['preview']:6.2f} s   (1024x1024, target <= 5 s)")
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
