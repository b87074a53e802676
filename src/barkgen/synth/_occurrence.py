"""Costs that spread the output's references over the exemplar: the occurrence penalty
(Kaspar et al. 2015 §5), controllable jitter (Lefebvre & Hoppe 2005) and, for label maps, the
label-area balance (Kopf et al. 2007's histogram matching in the discrete solver's cost).

They answer the "same patterns repeated" defect of laitoch2018 §4.1: every exemplar region is
used about equally, and small outputs still cover the whole exemplar (completeness).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from barkgen.synth._analysis import LevelAnalysis


def jitter_references(refs: np.ndarray, level: LevelAnalysis, amplitude: int, rng: np.random.Generator) -> np.ndarray:
    """Displace every reference by a seeded random offset in [-amplitude, amplitude]
    (Lefebvre & Hoppe 2005, controllable jitter)."""
    if amplitude <= 0:
        return refs
    ry, rx = level.coords_y[refs], level.coords_x[refs]
    jy = rng.integers(-amplitude, amplitude + 1, size=refs.shape, dtype=np.int32)
    jx = rng.integers(-amplitude, amplitude + 1, size=refs.shape, dtype=np.int32)
    ry = np.mod(ry + jy, level.height) if level.wrap[0] else np.clip(ry + jy, 0, level.height - 1)
    rx = np.mod(rx + jx, level.width) if level.wrap[1] else np.clip(rx + jx, 0, level.width - 1)
    return np.ascontiguousarray(ry * level.width + rx, dtype=np.int32)


def occurrence_penalty(
    refs: np.ndarray,
    level: LevelAnalysis,
    weight: float,
    radius: int,
    expected_use: np.ndarray | None = None,
    outside: tuple[np.ndarray, int] | None = None,
) -> np.ndarray:
    """Cost per exemplar pixel from how much more (or less) often its region is referenced than a
    uniform use of the exemplar would give (occurrence map, Kaspar et al. 2015 §5). With a guide,
    ``expected_use`` gives each exemplar pixel's uniform share (per label). ``outside``: when
    ``refs`` is one window of a level (:mod:`barkgen.synth._windows`), how often the rest of the
    level references each exemplar pixel and how many pixels the whole level has: the window
    is costed as part of the level, not as an output of its own."""
    n = level.height * level.width
    if weight <= 0:
        return np.zeros(n, np.float32)
    counts = np.bincount(refs.ravel(), minlength=n).astype(np.float32)
    pixels = refs.size
    if outside is not None:
        counts += outside[0]
        pixels = outside[1]
    counts = counts.reshape(level.height, level.width)
    k = 2 * radius + 1
    regional = box_blur(counts, k, level.wrap)
    if expected_use is None:
        expected = max(1.0, pixels / n)
        # > 0 for regions used more than their share, down to -1 (a bonus) for unused ones: small
        # outputs then still cover the whole exemplar (completeness)
        excess = regional / expected - 1.0
    else:
        share = box_blur(expected_use.reshape(level.height, level.width), k, level.wrap)
        # regions of labels the target does not want get neither cost nor bonus
        excess = np.where(share > 0, regional / np.maximum(share, 1.0) - 1.0, 0.0)
    return np.ascontiguousarray((weight * level.scale) * excess, dtype=np.float32).ravel()


def box_blur(image: np.ndarray, k: int, wrap: tuple[bool, bool]) -> np.ndarray:
    """``k x k`` box mean of a level's map, round the edges along the axes that wrap (else
    reflected)."""
    import cv2

    image = np.ascontiguousarray(image, dtype=np.float32)
    if not any(wrap):
        return cv2.blur(image, (k, k), borderType=cv2.BORDER_REFLECT_101)
    r = k // 2
    pad = np.pad(image, ((r, r), (0, 0)), mode="wrap" if wrap[0] else "reflect")
    pad = np.pad(pad, ((0, 0), (r, r)), mode="wrap" if wrap[1] else "reflect")
    return np.ascontiguousarray(cv2.blur(pad, (k, k))[r : r + image.shape[0], r : r + image.shape[1]])


@dataclass
class LabelBalance:
    """Keeps the label areas of a synthesized label map (histogram matching, Kopf et al. 2007,
    in the discrete solver's occurrence cost).

    ``shares[l]`` ``(h_l * w_l, L)``: how much of each label the full-resolution exemplar
    pixels under each pixel of level ``l`` have (finest first); ``fractions`` ``(L,)``: each
    label's share of the exemplar. The shares of the referenced pixels predict the final label
    areas already at coarse levels, where thin labels are not resolved; an exemplar pixel costs
    more the more it holds of labels the output has too much of, and less for labels it lacks,
    by ``weight`` x the relative excess (same units as the occurrence cost).
    """

    shares: list
    fractions: np.ndarray
    weight: float

    def penalty(self, refs: np.ndarray, level: int, scale: float) -> np.ndarray:
        shares = self.shares[level]
        current = shares[refs.ravel()].mean(axis=0)
        excess = np.clip(current / np.maximum(self.fractions, 1e-6) - 1.0, -1.0, 1.0)
        return shares @ (np.float32(self.weight * scale) * excess.astype(np.float32))
