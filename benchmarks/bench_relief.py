#!/usr/bin/env python3
"""Relief from a photo alone, measured on photos whose answer is known (issue 33, part 1).

    .venv/bin/python benchmarks/bench_relief.py [--quick] [--scans NAME ...] [--json F]

Each case is rendered, so its truth is known:

- the height: a scanned bark's normals (``../shared/data/bark_maps``) integrated
  (Frankot-Chellappa), and those normals;
- the albedo: the scan's own colour photo *flattened* (its luminance divided by a 16 px blur of
  it, so its fine structure and the shading in it are gone, its colours and broad tones kept),
  or the colour photo of *another* scan as it is (resized): a patterned albedo that owes
  nothing to this height, the hard case for any photo-only method;
- the light: a known direction (azimuth counter-clockwise from the right, elevation above the
  surface); the photo is ``albedo x (ambient + (1 - ambient) max(N·L, 0))`` in linear light,
  with an ambient of 0.25, and, in the ``+AO`` cases, times the scan's AO.

barkgen's photo-only path (:func:`barkgen.material.make_material`, its height's band weights
fitted leave-one-out on the other three scans, as ``bench_material.py`` does) then estimates
albedo, light, height and normals, and the table says how close each came:

- ``photo r`` / ``albedo r``: correlation of the luminance with the *true* ``N·L``, of the
  rendered photo and of the estimated albedo (target: at most 0.1 where the photo's is 0.3 or
  more);
- ``albedo err``: the mean absolute difference of the estimated albedo from the true one (each
  channel's gain matched by least squares), over the same for the rendered photo (target: at
  most 0.5);
- ``az err`` / ``el err``: the estimated light's angles against the true ones (target: azimuth
  within 20 degrees where the light is 15 degrees or more off the normal);
- ``height r``: correlation of the estimated height with the true one, both band-passed (a
  Gaussian of 32 px taken off: the integrated height's slow drift is no relief);
- ``normal err``: mean angle to the true normals, and over a flat normal map's;
- ``oracle r``: what shape from shading reaches when told the true light (not what barkgen
  does): the log-luminance's high-pass integrated along the light's azimuth by Fourier division
  by the directional derivative (:func:`integrated_along`), its height correlation as above. A
  reference for estimating the light and the height from the shading.

The real photos' own figures are printed beside (their true albedo and light are unknown):
height correlation and normal error against their scans.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
from scipy import ndimage as ndi

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_material as bm  # noqa: E402  (its scans, loaders, fit and measures)

from barkgen._shared.arrays import unit_float  # noqa: E402
from barkgen.color import linear_to_srgb, srgb_to_linear  # noqa: E402
from barkgen.material import Light, MaterialOptions, make_material, shading  # noqa: E402
from barkgen.material.height import luminance  # noqa: E402

#: (azimuth, elevation) of the lights, degrees
LIGHTS = ((30.0, 35.0), (150.0, 60.0), (260.0, 20.0))
AMBIENT = 0.25
#: the band taken off heights before they are compared (the integrated height drifts)
HEIGHT_BAND = 32.0
#: the blur (px) whose luminance a flattened albedo keeps
FLATTEN = 16.0


def flattened(photo: np.ndarray) -> np.ndarray:
    """A photo's colour with its fine luminance structure taken out: each pixel scaled so its
    luminance is the 16 px blur's."""
    lum = np.maximum(luminance(photo), 1e-3)
    return np.clip(photo * (ndi.gaussian_filter(lum, FLATTEN, mode="reflect") / lum)[..., None], 0.0, 1.0)


def gain_matched_error(estimate: np.ndarray, truth: np.ndarray) -> float:
    """Mean absolute difference after each channel's gain is matched by least squares."""
    est = estimate.reshape(-1, estimate.shape[-1]).astype(np.float64)
    tru = truth.reshape(-1, truth.shape[-1]).astype(np.float64)
    gain = (est * tru).sum(axis=0) / np.maximum((est * est).sum(axis=0), 1e-12)
    return float(np.abs(est * gain - tru).mean())


def correlation(a: np.ndarray, b: np.ndarray) -> float:
    a = np.asarray(a, np.float64).ravel()
    b = np.asarray(b, np.float64).ravel()
    a, b = a - a.mean(), b - b.mean()
    return float((a @ b) / max(np.sqrt((a @ a) * (b @ b)), 1e-12))


def band(height: np.ndarray) -> np.ndarray:
    return height - ndi.gaussian_filter(height, HEIGHT_BAND, mode="wrap")


def angle_error(estimated: Light, azimuth: float, elevation: float) -> tuple[float, float]:
    az = abs((estimated.azimuth - azimuth + 180.0) % 360.0 - 180.0)
    return az, abs(estimated.elevation - elevation)


def render(albedo: np.ndarray, normals: np.ndarray, light: Light, ao: np.ndarray | None) -> np.ndarray:
    """The photo of ``albedo`` (sRGB, float) on ``normals`` under ``light``, sRGB float."""
    shade = AMBIENT + (1.0 - AMBIENT) * np.maximum(shading(normals, light), 0.0)
    if ao is not None:
        shade = shade * ao
    return np.clip(linear_to_srgb(srgb_to_linear(albedo) * shade[..., None]), 0.0, 1.0).astype(np.float32)


def measure(photo, truth_normals, truth_height, config, light_true=None, albedo=None) -> dict:
    """barkgen's estimates from ``photo`` against the truth (albedo and light where known)."""
    material = make_material(photo, MaterialOptions(height=config, exemplar_wrap="no"))
    row = {
        "height_r": correlation(band(material.height), band(truth_height)),
        "normal_err": bm.angular_error(material.normals, truth_normals),
        "flat_err": bm.flat_error(truth_normals),
    }
    row["normal_ratio"] = row["normal_err"] / row["flat_err"]
    if light_true is not None:
        n_dot_l = shading(truth_normals, light_true)
        row["photo_r"] = correlation(luminance(photo), n_dot_l)
        row["albedo_r"] = correlation(luminance(material.color), n_dot_l)
        row["albedo_err_ratio"] = gain_matched_error(material.color, albedo) / gain_matched_error(photo, albedo)
        row["az_err"], row["el_err"] = angle_error(material.light, light_true.azimuth, light_true.elevation)
        row["light"] = [round(material.light.azimuth, 1), round(material.light.elevation, 1)]
        row["oracle_r"] = correlation(band(integrated_along(photo, light_true.azimuth)), band(truth_height))
    return row


def integrated_along(photo: np.ndarray, azimuth: float, regulariser: float = 0.02) -> np.ndarray:
    """The height whose fall towards the light at ``azimuth`` (degrees counter-clockwise from the
    right, +y up) best explains the log-luminance's high-pass (16 px): a surface is brighter
    where it faces the light, i.e. where it falls towards it (``N·L`` grows as ``-dh/ds`` along
    the light's direction ``s``). Its Fourier transform divided by minus the directional
    derivative's, regularised where that is small."""
    lum = np.log(np.maximum(luminance(photo), 1e-3))
    high = lum - ndi.gaussian_filter(lum, FLATTEN, mode="wrap")
    h, w = high.shape
    wx = np.fft.fftfreq(w)[None, :] * 2 * np.pi
    wy = np.fft.fftfreq(h)[:, None] * 2 * np.pi
    turn = np.radians(azimuth)
    # the rise towards the light: d/dx cos + d/dy sin, with y up the screen (rows down)
    derivative = 1j * (wx * np.cos(turn) - wy * np.sin(turn))
    spectrum = -np.fft.fft2(high) * np.conj(derivative) / (np.abs(derivative) ** 2 + regulariser)
    spectrum[0, 0] = 0.0
    return np.real(np.fft.ifft2(spectrum))


def resized(image: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    import cv2

    return cv2.resize(image, (shape[1], shape[0]), interpolation=cv2.INTER_AREA)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="one light per scan, no AO cases")
    parser.add_argument("--scans", nargs="*", help="only these scans (stems)")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    names = [n for n in bm.SCANNED if not args.scans or n in args.scans]
    cases = {name: bm.load_case(name) for name in bm.SCANNED}
    lights = LIGHTS[:1] if args.quick else LIGHTS
    rows = []
    print(
        f"{'case':44} {'photo r':>7} {'albedo r':>8} {'albedo err':>10} {'az err':>6} {'el err':>6} "
        f"{'height r':>8} {'normal err':>10} {'oracle r':>8}"
    )
    for name in names:
        case = cases[name]
        others = [cases[n] for n in bm.SCANNED if n != name]
        config = bm.fit_config(others)  # leave-one-out
        normals = case["truth"]
        height = bm.frankot_chellappa(normals)
        source = bm.SCANNED[(bm.SCANNED.index(name) + 1) % len(bm.SCANNED)]
        albedos = {
            "flat": flattened(unit_float(case["photo"])).astype(np.float32),
            source.split("_")[0]: resized(unit_float(cases[source]["photo"]), normals.shape[:2]),
        }
        real = measure(unit_float(case["photo"]), normals, height, config)
        rows.append({"case": f"{name} (the real photo)", **real})
        print(
            f"{name + ' (the real photo)':44} {'':>7} {'':>8} {'':>10} {'':>6} {'':>6} "
            f"{real['height_r']:8.2f} {real['normal_ratio']:9.2f}x",
            flush=True,
        )
        variants = [("flat", False)] if args.quick else [("flat", False), ("flat", True), (source.split("_")[0], False)]
        for azimuth, elevation in lights:
            for kind, with_ao in variants:
                light = Light(azimuth, elevation)
                albedo = albedos[kind]
                photo = render(albedo, normals, light, case["ao"] if with_ao else None)
                label = f"{name} {kind} L{azimuth:.0f}/{elevation:.0f}{' +AO' if with_ao else ''}"
                row = {"case": label, **measure(photo, normals, height, config, light, albedo)}
                rows.append(row)
                print(
                    f"{label:44} {row['photo_r']:7.2f} {row['albedo_r']:8.2f} {row['albedo_err_ratio']:10.2f} "
                    f"{row['az_err']:6.1f} {row['el_err']:6.1f} {row['height_r']:8.2f} {row['normal_ratio']:9.2f}x "
                    f"{row['oracle_r']:8.2f}",
                    flush=True,
                )
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
