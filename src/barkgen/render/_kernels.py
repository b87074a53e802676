"""Numba kernels of the trunk renderer."""

from __future__ import annotations

import numpy as np
from numba import njit, prange


@njit(cache=True)
def _bilinear(img: np.ndarray, u: float, v: float, c: int) -> float:
    """Sample channel ``c`` of ``img`` (h, w, C) at texture coordinates (u, v) in texels, wrapping."""
    h, w = img.shape[0], img.shape[1]
    x0 = np.floor(u)
    y0 = np.floor(v)
    fx = u - x0
    fy = v - y0
    xa = int(x0) % w
    ya = int(y0) % h
    xb = (xa + 1) % w
    yb = (ya + 1) % h
    top = img[ya, xa, c] * (1 - fx) + img[ya, xb, c] * fx
    bottom = img[yb, xa, c] * (1 - fx) + img[yb, xb, c] * fx
    return top * (1 - fy) + bottom * fy


@njit(parallel=True, cache=True)
def render_rows(
    maps: np.ndarray,
    out_h: int,
    out_w: int,
    radius: float,
    texel: float,
    amplitude: float,
    midlevel: float,
    light: np.ndarray,
    ambient: float,
    background: np.ndarray,
) -> np.ndarray:
    """Orthographic view of a vertical cylinder carrying the material ``maps`` (h, w, 9):
    linear albedo RGB, displacement 0..1, normal (OpenGL) xyz, AO, roughness.

    Each screen row is a horizontal slice of the trunk: points around its circumference, pushed
    out by the displacement, are splatted into a per-row depth buffer (so the relief shows on
    the silhouette and hides what it should), then lit: Lambert with the tangent-space normal
    turned onto the cylinder, ambient scaled by AO, and a Blinn-Phong highlight whose width
    follows the roughness. ``texel``: screen pixels per texture pixel; ``amplitude``: screen
    pixels of a displacement of 1. Returns linear RGB (out_h, out_w, 3).
    """
    out = np.empty((out_h, out_w, 3), np.float32)
    cx = out_w * 0.5
    n_samples = 4 * out_w
    circumference_tex = 2.0 * np.pi * radius / texel
    hx = light[0]
    hy = light[1]
    hz = light[2] + 1.0
    hn = np.sqrt(hx * hx + hy * hy + hz * hz)
    hx /= hn
    hy /= hn
    hz /= hn
    for y in prange(out_h):
        depth = np.full(out_w, -1e30)
        hit_phi = np.zeros(out_w)
        v = y / texel
        for j in range(n_samples):
            phi = -np.pi + 2.0 * np.pi * (j + 0.5) / n_samples
            u = (phi + np.pi) / (2.0 * np.pi) * circumference_tex
            d = (_bilinear(maps, u, v, 3) - midlevel) * amplitude
            r = radius + d
            z = r * np.cos(phi)
            x = int(np.floor(cx + r * np.sin(phi)))
            if 0 <= x < out_w and z > depth[x]:
                depth[x] = z
                hit_phi[x] = phi
        for x in range(out_w):
            if depth[x] < -0.2 * radius:  # no hit, or only the back of the trunk
                for c in range(3):
                    out[y, x, c] = background[c] * (1.0 - 0.35 * y / out_h)
                continue
            phi = hit_phi[x]
            u = (phi + np.pi) / (2.0 * np.pi) * circumference_tex
            tnx = _bilinear(maps, u, v, 4)
            tny = _bilinear(maps, u, v, 5)
            tnz = _bilinear(maps, u, v, 6)
            s = np.sin(phi)
            co = np.cos(phi)
            # tangent (+u) = (cos, 0, -sin), bitangent (+v up) = (0, 1, 0), normal = (sin, 0, cos)
            nx = tnx * co + tnz * s
            ny = tny
            nz = -tnx * s + tnz * co
            nn = np.sqrt(nx * nx + ny * ny + nz * nz) + 1e-12
            nx /= nn
            ny /= nn
            nz /= nn
            lam = max(nx * light[0] + ny * light[1] + nz * light[2], 0.0)
            ao = _bilinear(maps, u, v, 7)
            rough = min(max(_bilinear(maps, u, v, 8), 0.05), 1.0)
            shininess = 2.0 / (rough**4) - 2.0
            spec_dot = max(nx * hx + ny * hy + nz * hz, 0.0)
            spec = 0.04 * (shininess + 8.0) / (8.0 * np.pi) * spec_dot**shininess * lam
            for c in range(3):
                albedo = _bilinear(maps, u, v, c)
                out[y, x, c] = albedo * (ambient * ao + (1.0 - ambient) * lam * 1.6) + spec
    return out


@njit(cache=True)
def rasterize_mesh(screen, faces, out_h, out_w, triangle, barycentric, depth):
    """A z-buffer pass: every pixel centre of ``(out_h, out_w)`` covered by a triangle of
    ``faces`` whose vertices are at ``screen`` ``(n, 3)`` (column, row, depth: nearer is
    smaller) gets the nearest one's index in ``triangle`` and its barycentric coordinates
    (perspective-free: an orthographic view). Triangles facing away are skipped; they are drawn
    in order, so the result does not depend on threads."""
    for f in range(faces.shape[0]):
        a, b, c = faces[f, 0], faces[f, 1], faces[f, 2]
        x0, y0, z0 = screen[a, 0], screen[a, 1], screen[a, 2]
        x1, y1, z1 = screen[b, 0], screen[b, 1], screen[b, 2]
        x2, y2, z2 = screen[c, 0], screen[c, 1], screen[c, 2]
        det = (y1 - y2) * (x0 - x2) + (x2 - x1) * (y0 - y2)
        if det >= -1e-12:  # clockwise on screen (rows down): facing away, or degenerate
            continue
        lo_x = max(int(np.floor(min(x0, min(x1, x2)))), 0)
        hi_x = min(int(np.ceil(max(x0, max(x1, x2)))), out_w - 1)
        lo_y = max(int(np.floor(min(y0, min(y1, y2)))), 0)
        hi_y = min(int(np.ceil(max(y0, max(y1, y2)))), out_h - 1)
        for y in range(lo_y, hi_y + 1):
            py = y + 0.5
            for x in range(lo_x, hi_x + 1):
                px = x + 0.5
                w0 = ((y1 - y2) * (px - x2) + (x2 - x1) * (py - y2)) / det
                w1 = ((y2 - y0) * (px - x2) + (x0 - x2) * (py - y2)) / det
                w2 = 1.0 - w0 - w1
                if w0 < 0 or w1 < 0 or w2 < 0:
                    continue
                z = w0 * z0 + w1 * z1 + w2 * z2
                if z < depth[y, x]:
                    depth[y, x] = z
                    triangle[y, x] = f
                    barycentric[y, x, 0] = w0
                    barycentric[y, x, 1] = w1
                    barycentric[y, x, 2] = w2
