"""Comparing structures (sibbing2010 §6, Fig. 7): angle and thickness histograms, junctions,
intersections, and a picture of the histograms side by side."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np

from barkgen.branching.model import histogram
from barkgen.branching.structure import (
    Structure,
    junction_radius,
    resample_polyline,
    turning_angles,
)


def structure_values(structure: Structure, step: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """All turning angles (radians) and all vertex thicknesses, after resampling at ``step``
    (default: the structure's own)."""
    h = float(step or structure.step)
    angles, thickness = [], []
    for b in structure.branches:
        p = resample_polyline(b.points, h)
        if len(p) >= 3:
            angles.append(turning_angles(p[:, :2]))
        thickness.append(p[:, 2])
    a = np.concatenate(angles) if angles else np.zeros(0)
    return a, np.concatenate(thickness)


def _headings(structure: Structure) -> np.ndarray:
    """Directions of every edge as axes in [0, pi)."""
    parts = [np.arctan2(*np.diff(b.xy, axis=0)[:, ::-1].T) for b in structure.branches]
    return np.mod(np.concatenate(parts), np.pi) if parts else np.zeros(0)


def self_intersections(structure: Structure) -> int:
    """Crossings of two branches that are not a furcation or a merge of the structure: places
    where the skeletons of different branches touch away from their recorded junctions."""
    return int(cv2.connectedComponents(intersection_mask(structure), connectivity=8)[0] - 1)


def intersection_mask(structure: Structure) -> np.ndarray:
    """uint8 mask of the pixels counted by :func:`self_intersections` (on the torus for a
    :attr:`~Structure.periodic` structure)."""
    h, w = structure.height, structure.width
    periodic = structure.periodic
    owner = np.full((h, w), -1, np.int32)
    crossing = np.zeros((h, w), np.uint8)
    junctions = np.zeros((h, w), np.uint8)
    copies = [(dx, dy) for dy in (-h, 0, h) for dx in (-w, 0, w)] if periodic else [(0, 0)]
    for b in structure.branches:
        for ref, v, own in ((b.parent, b.parent_vertex, b.points[0, 2]), (b.joins, b.join_vertex, b.points[-1, 2])):
            if ref is not None:
                x, y, r = structure.branches[ref].points[v]
                if periodic:
                    x, y = x % w, y % h
                radius = int(np.ceil(junction_radius(r, own, structure.step)))
                for dx, dy in copies:
                    cv2.circle(junctions, (int(round(x + dx)), int(round(y + dy))), radius, 1, -1)
    for i, b in enumerate(structure.branches):
        pts = np.round(b.xy).astype(np.int64)
        if periodic:  # moved by whole periods to start in the image
            pts -= (pts[0] // (w, h)) * (w, h)
        x0, y0 = pts.min(axis=0) - 1
        x1, y1 = pts.max(axis=0) + 2
        mask = np.zeros((y1 - y0, x1 - x0), np.uint8)
        cv2.polylines(mask, [(pts - [x0, y0]).astype(np.int32)], False, 1, 1)
        yy, xx = np.nonzero(mask)
        yy, xx = yy + y0, xx + x0
        if periodic:
            yy, xx = yy % h, xx % w
        else:
            keep = (yy >= 0) & (yy < h) & (xx >= 0) & (xx < w)
            yy, xx = yy[keep], xx[keep]
        sub = owner[yy, xx]
        hit = (sub >= 0) & (sub != i)
        crossing[yy[hit], xx[hit]] = 1
        owner[yy, xx] = i
    crossing[junctions > 0] = 0
    return crossing


@dataclass
class StructureComparison:
    """Histograms of a source and a target structure on the source's bins (B = 16)."""

    angle_edges: np.ndarray
    thickness_edges: np.ndarray
    source_angles: np.ndarray
    target_angles: np.ndarray
    source_thickness: np.ndarray
    target_thickness: np.ndarray
    angle_l1: float
    thickness_l1: float
    heading_l1: float  # edge directions as axes, 16 bins over 0-180 degrees
    source_junction_density: float  # furcations + merges per megapixel
    target_junction_density: float
    source_length_density: float  # skeleton pixels per pixel
    target_length_density: float
    target_intersections: int
    source_free_end_density: float = 0.0  # branch ends connected to nothing, per megapixel
    target_free_end_density: float = 0.0

    def as_dict(self) -> dict:
        return {
            "angle_l1": self.angle_l1,
            "thickness_l1": self.thickness_l1,
            "heading_l1": self.heading_l1,
            "source_junctions_per_mpx": self.source_junction_density,
            "target_junctions_per_mpx": self.target_junction_density,
            "source_length_per_px": self.source_length_density,
            "target_length_per_px": self.target_length_density,
            "target_intersections": self.target_intersections,
            "source_free_ends_per_mpx": self.source_free_end_density,
            "target_free_ends_per_mpx": self.target_free_end_density,
        }


def compare_structures(source: Structure, target: Structure, bins: int = 16) -> StructureComparison:
    """The paper's Fig. 7 evaluation as numbers: L1 distances (0 = equal, 2 = disjoint) between
    the normalised angle and thickness histograms, both on ``bins`` bins between the source's
    minimum and maximum (values outside count in the end bins), at the source's step."""
    sa, sr = structure_values(source)
    ta, tr = structure_values(target, source.step)
    a_edges = np.linspace(sa.min(), sa.max(), bins + 1) if len(sa) else np.linspace(-np.pi, np.pi, bins + 1)
    lo, hi = float(sr.min()), float(sr.max())
    if hi - lo < 1e-6:
        lo, hi = lo * 0.9, hi * 1.1 + 1e-3
    r_edges = np.linspace(lo, hi, bins + 1)
    hs_a, ht_a = histogram(sa, a_edges), histogram(ta, a_edges)
    hs_r, ht_r = histogram(sr, r_edges), histogram(tr, r_edges)
    h_edges = np.linspace(0, np.pi, bins + 1)
    heading_l1 = float(np.abs(histogram(_headings(source), h_edges) - histogram(_headings(target), h_edges)).sum())
    s_area = source.width * source.height / 1e6
    t_area = target.width * target.height / 1e6
    return StructureComparison(
        a_edges,
        r_edges,
        hs_a,
        ht_a,
        hs_r,
        ht_r,
        float(np.abs(hs_a - ht_a).sum()),
        float(np.abs(hs_r - ht_r).sum()),
        heading_l1,
        source.junctions() / s_area,
        target.junctions() / t_area,
        source.total_length() / (s_area * 1e6),
        target.total_length() / (t_area * 1e6),
        self_intersections(target),
        source.free_ends() / s_area,
        target.free_ends() / t_area,
    )


def comparison_plot(cmp: StructureComparison, width: int = 960, height: int = 360) -> np.ndarray:
    """Fig. 7-style picture: angle (left) and thickness (right) histograms of the source (grey
    bars) and the target (orange outline) on top of each other. Returns uint8 RGB."""
    img = np.full((height, width, 3), 255, np.uint8)
    pad, gap = 40, 40
    panel_w = (width - 2 * pad - gap) // 2
    panels: tuple[tuple[np.ndarray, np.ndarray, np.ndarray, str, Callable[[float], float]], ...] = (
        (
            cmp.angle_edges,
            cmp.source_angles,
            cmp.target_angles,
            f"turning angle (deg)   L1 = {cmp.angle_l1:.3f}",
            np.degrees,
        ),
        (
            cmp.thickness_edges,
            cmp.source_thickness,
            cmp.target_thickness,
            f"thickness (px)   L1 = {cmp.thickness_l1:.3f}",
            lambda v: v,
        ),
    )
    for p, (edges, src, dst, title, unit) in enumerate(panels):
        x0 = pad + p * (panel_w + gap)
        y0, y1 = pad, height - pad
        top = max(src.max(), dst.max(), 1e-9)
        n = len(src)
        bw = panel_w / n
        for i in range(n):
            xa, xb = int(x0 + i * bw), int(x0 + (i + 1) * bw) - 1
            hs = int((y1 - y0) * src[i] / top)
            ht = int((y1 - y0) * dst[i] / top)
            cv2.rectangle(img, (xa, y1 - hs), (xb, y1), (170, 170, 170), -1)
            cv2.rectangle(img, (xa, y1 - ht), (xb, y1), (230, 120, 20), 2)
        cv2.line(img, (x0, y1), (x0 + panel_w, y1), (0, 0, 0), 1)
        cv2.putText(img, title, (x0, y0 - 14), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 0), 1, cv2.LINE_AA)
        for v, anchor in ((edges[0], x0), (edges[-1], x0 + panel_w - 40)):
            cv2.putText(
                img, f"{unit(v):.1f}", (anchor, y1 + 18), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 1, cv2.LINE_AA
            )
    cv2.putText(
        img,
        "grey: source   orange: target",
        (pad, height - 8),
        cv2.FONT_HERSHEY_SIMPLEX,
        0.45,
        (60, 60, 60),
        1,
        cv2.LINE_AA,
    )
    return img
