"""Numba kernels of structure growth (sibbing2010 §4.2-4.4): the contact and density maps
(local space-colonisation updates), the extension step, the furcation classifier's choices."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def commit_points(
    dist, near_branch, near_vertex, near_tangent, points, first, last, branch, radius, track=True, wrap=False
):  # pragma: no cover - compiled
    """Lower ``dist`` (distance to the nearest committed branch surface, i.e. distance to a
    vertex minus its thickness) within ``radius`` of each vertex ``points[first:last]`` (rows
    x, y, thickness) of ``branch``, and (with ``track``) remember which branch and vertex is
    nearest and the branch's direction there. Only the ``3 rho`` vicinity is touched (§4.4).
    With ``wrap`` the maps are a torus: vertices anywhere on the plane land at their place
    modulo the map's size, and their vicinity runs on across its edges."""
    h, w = dist.shape
    n = points.shape[0]
    r2 = radius * radius
    for i in range(first, min(last, n)):
        x, y, r = points[i, 0], points[i, 1], points[i, 2]
        a = max(i - 1, 0)
        c = min(i + 1, n - 1)
        tangent = np.arctan2(points[c, 1] - points[a, 1], points[c, 0] - points[a, 0])
        x0 = int(np.floor(x - radius))
        x1 = int(np.ceil(x + radius))
        y0 = int(np.floor(y - radius))
        y1 = int(np.ceil(y + radius))
        if not wrap:
            x0, x1, y0, y1 = max(x0, 0), min(x1, w - 1), max(y0, 0), min(y1, h - 1)
        for yy in range(y0, y1 + 1):
            dy2 = (yy - y) ** 2
            my = yy % h
            for xx in range(x0, x1 + 1):
                e2 = (xx - x) ** 2 + dy2
                if e2 > r2:
                    continue
                mx = xx % w
                bound = dist[my, mx] + r
                if bound > 0 and e2 >= bound * bound:
                    continue
                d = np.sqrt(e2) - r
                if d < dist[my, mx]:
                    dist[my, mx] = d
                    if track:
                        near_branch[my, mx] = branch
                        near_vertex[my, mx] = i
                        near_tangent[my, mx] = tangent


@njit(cache=True)
def sample_nearest(arr, xs, ys, outside, out, inside, wrap):  # pragma: no cover - compiled
    """Nearest-pixel lookup of ``arr`` at float positions (any shape, flattened); positions
    outside the image get ``outside`` (with ``wrap``, none is: the image is a torus)."""
    fx = xs.ravel()
    fy = ys.ravel()
    o = out.ravel()
    ins = inside.ravel()
    for i in range(fx.shape[0]):
        o[i], ins[i] = _lookup(arr, fx[i], fy[i], outside, wrap)


@njit(cache=True)
def _lookup(arr, x, y, outside, wrap):  # pragma: no cover - compiled
    """``(arr at the pixel nearest to (x, y), inside)``; outside the image ``(outside, False)``,
    unless ``wrap``: then the image is a torus and every position is inside."""
    h, w = arr.shape
    xi = int(np.floor(x + 0.5))
    yi = int(np.floor(y + 0.5))
    if wrap:
        return arr[yi % h, xi % w], True
    if 0 <= xi < w and 0 <= yi < h:
        return arr[yi, xi], True
    return outside, False


@njit(cache=True)
def _contact(dist, near_branch, x, y, r, step, branch, parent, sx, sy, exempt, wrap):  # pragma: no cover - compiled
    """(inside the image, touches a committed branch) for a new vertex of thickness ``r``: the
    vertices of one branch are ``step`` apart, so bodies closer than ``r + 0.75 step`` touch;
    a branch never touches itself and a child may touch its parent within ``exempt`` of the
    furcation it starts from (sx, sy). ``wrap``: the maps are a torus."""
    d, inside = _lookup(dist, x, y, np.float32(1e6), wrap)
    if not inside:
        return False, False
    nb, _ = _lookup(near_branch, x, y, np.int32(-1), wrap)
    if nb == branch:
        return True, False
    if nb == parent and np.sqrt((x - sx) ** 2 + (y - sy) ** 2) <= exempt:
        return True, False
    return True, d < r + 0.75 * step


@njit(cache=True)
def first_contacts(
    dist, near_branch, xs, ys, rs, step, branch, parent, sx, sy, exempt, wrap
):  # pragma: no cover - compiled
    """(first vertex touching a committed branch, first vertex outside the image) along one
    path of vertices; -1 where there is none. See :func:`_contact`."""
    first_hit = -1
    for j in range(xs.shape[0]):
        inside, touch = _contact(dist, near_branch, xs[j], ys[j], rs[j], step, branch, parent, sx, sy, exempt, wrap)
        if not inside:
            return first_hit, j
        if touch and first_hit < 0:
            first_hit = j
    return first_hit, -1


@njit(cache=True)
def path_contacts(x0, y0, theta, step, elements, contact):  # pragma: no cover - compiled
    """The vertices of element rows (angle, thickness) appended from ``(x0, y0)`` at heading
    ``theta`` (``step`` apart), their headings, and the first vertex touching a committed
    branch and the first leaving the image (-1: none; :func:`first_contacts`); ``contact =
    (dist, near_branch, branch, parent, sx, sy, exempt, wrap)`` as :func:`extension_candidates`
    takes it."""
    dist, near_branch, branch, parent, sx, sy, exempt, wrap = contact
    n = elements.shape[0]
    xs = np.empty(n)
    ys = np.empty(n)
    heads = np.empty(n)
    hd = theta
    hx = x0
    hy = y0
    for j in range(n):
        hd += elements[j, 0]
        hx += step * np.cos(hd)
        hy += step * np.sin(hd)
        xs[j] = hx
        ys[j] = hy
        heads[j] = hd
    first_hit, first_out = first_contacts(
        dist, near_branch, xs, ys, elements[:, 1].copy(), step, branch, parent, sx, sy, exempt, wrap
    )
    return xs, ys, heads, first_hit, first_out


@njit(cache=True)
def extension_candidates(
    histories, recent, k, m, matching, tip, contact, density, choice, qual, out, decision
):  # pragma: no cover - compiled
    """One extension step of sibbing2010 §4.2-4.4 for the ``T = len(cand)`` best histories.

    Bending quality of every history against the branch's last ``len(ha)`` elements; the ``T``
    best are kept (ties by index); for each: its continuation (up to ``m`` elements, fewer where
    the source branch ends), the histogram-matched score ``Q*``, the vertices it would add, the
    first vertex touching a committed branch (a child may touch its parent only within
    ``exempt`` of its start; ``dist``, ``near_branch``: the contact maps) and the first leaving
    the image, and ``Q** = Q* / (D + eps)`` with ``D`` the maximum density (from ``density``,
    the distance to everything grown so far, times the guide) along its chord up to three
    times its length.

    Then the choice, with the three ``uniforms``: one of the ``c_best`` best by ``Q*`` with
    probability proportional to it (the paper); if that one would cross a branch it ends on it
    (a merge) with probability ``join_rate`` times the likelihood of its incidence angle in the
    source (``join_pdf``, 6 bins over 0-90 degrees), else it is rejected and the choice is made
    among the free candidates by ``Q**``. ``decision`` gets ``(code, t, j)``: code 0 = no
    candidate, 1 = grow by candidate ``t`` (``j`` vertices inside the image), 2 = candidate
    ``t`` ends the branch, 3 = merge: candidate ``t`` up to its vertex ``j``.

    The arguments, packed by what they are:

    - ``histories = (hist_a, hist_r, history_start, branch_end, angles, thickness)``: the
      source's ``k + 1``-element histories (angles, thicknesses), where each starts and its
      branch ends in the element arrays ``angles``, ``thickness``;
    - ``recent = (ha, hr)``: the growing branch's last elements; ``k``, ``m``: the history and
      continuation lengths;
    - ``matching = (a_edges, r_edges, a_counts, r_counts, a_target, r_target, h_counts,
      h_target, n_t, omega_g)``: the three histograms of §4.2 (edges, counts so far over
      ``n_t`` elements, the source's), and the weight of matching them;
    - ``tip = (x0, y0, theta, step)``: where the branch is, its heading and the step h;
    - ``contact = (dist, near_branch, branch, parent, sx, sy, exempt, wrap)``: see
      :func:`_contact` (``wrap``: every map is a torus);
    - ``density = (density, guide, use_guide, rho, eps, wrap)``: the density map, the optional
      guide, the space-colonisation ``rho`` and the regulariser of ``Q**``;
    - ``choice = (c_best, uniforms, join_rate, join_pdf, near_tangent, wrap)``;
    - ``qual``: scratch for every history's quality; ``out = (cand, qstar, lens, ang, thk, xs,
      ys, heads, first_hit, first_out, q2)``: per candidate (rows ``T``).
    """
    cand, qstar, lens, ang, thk, xs, ys, heads, first_hit, first_out, q2 = out
    _bending_qualities(qual, histories[0], histories[1], recent[0], recent[1])
    _best_histories(qual, cand, qstar)
    _continuations(histories, k, m, cand, lens, ang, thk, qstar, q2, first_hit, first_out)
    _match_histograms(matching, tip[2], m, cand, lens, ang, thk, qstar)
    _trace_candidates(cand, lens, ang, thk, xs, ys, heads, first_hit, first_out, tip, contact)
    _chord_scores(cand, lens, qstar, xs, ys, q2, tip, density)
    _decide(choice, cand, qstar, lens, xs, ys, heads, first_hit, first_out, q2, decision)


@njit(cache=True)
def _bending_qualities(qual, hist_a, hist_r, ha, hr):  # pragma: no cover - compiled
    """§4.2's bending quality of every source history against the branch's last elements
    ``(ha, hr)`` (the histories' last ``len(ha)`` columns)."""
    n_hist = hist_a.shape[0]
    width = hist_a.shape[1]
    q = ha.shape[0]
    off = width - q
    for i in range(n_hist):
        sa = 0.0
        sr = 0.0
        for j in range(q):
            da = hist_a[i, off + j] - ha[j]
            dr = hist_r[i, off + j] - hr[j]
            sa += da * da
            sr += dr * dr
        qual[i] = (1.0 / (np.sqrt(sa) + 1.0) + 1.0) * (1.0 / (np.sqrt(sr) + 1.0) + 1.0)


@njit(cache=True)
def _best_histories(qual, cand, qstar):  # pragma: no cover - compiled
    """The ``len(cand)`` best qualities in ``qstar`` and their histories in ``cand`` (-1: none),
    best first (stable: the lower index wins a tie)."""
    t_count = cand.shape[0]
    for t in range(t_count):
        cand[t] = -1
        qstar[t] = -1.0
    for i in range(qual.shape[0]):
        v = qual[i]
        if v <= qstar[t_count - 1]:
            continue
        p = t_count - 1
        while p > 0 and qstar[p - 1] < v:
            qstar[p] = qstar[p - 1]
            cand[p] = cand[p - 1]
            p -= 1
        qstar[p] = v
        cand[p] = i


@njit(cache=True)
def _continuations(
    histories, k, m, cand, lens, ang, thk, qstar, q2, first_hit, first_out
):  # pragma: no cover - compiled
    """Each candidate's continuation: the (up to ``m``) source elements after its history, zeros
    beyond, and its length in ``lens``; rows without a candidate are cleared."""
    history_start, branch_end, angles, thickness = histories[2], histories[3], histories[4], histories[5]
    for t in range(cand.shape[0]):
        c = cand[t]
        if c < 0:
            lens[t] = 0
            qstar[t] = 0.0
            q2[t] = 0.0
            first_hit[t] = -1
            first_out[t] = -1
            continue
        c0 = history_start[c] + k + 1
        n_el = min(max(branch_end[c] - c0, 0), m)
        lens[t] = n_el
        for j in range(m):
            if j < n_el:
                ang[t, j] = angles[c0 + j]
                thk[t, j] = thickness[c0 + j]
            else:
                ang[t, j] = 0.0
                thk[t, j] = 0.0


@njit(cache=True)
def _match_histograms(matching, theta, m, cand, lens, ang, thk, qstar):  # pragma: no cover - compiled
    """§4.2's histogram matching: every candidate's ``Q*`` times ``exp(gain)`` (clipped to
    ``e^+-50``), the gain being how much appending its continuation from heading ``theta``
    brings the three histograms nearer the source's, times ``omega_g n_t / m``."""
    a_edges, r_edges, a_counts, r_counts, a_target, r_target, h_counts, h_target, n_t, omega_g = matching
    bins = a_counts.shape[0]
    n_now = max(n_t, 1.0)
    before = 0.0
    for b in range(bins):
        before += (a_target[b] - a_counts[b] / n_now) ** 2 + (r_target[b] - r_counts[b] / n_now) ** 2
        before += (h_target[b] - h_counts[b] / n_now) ** 2
    before /= bins
    add_a = np.zeros(bins)
    add_r = np.zeros(bins)
    add_h = np.zeros(bins)
    for t in range(cand.shape[0]):
        if cand[t] < 0:
            continue
        n_el = lens[t]
        add_a[:] = 0.0
        add_r[:] = 0.0
        add_h[:] = 0.0
        hd = theta
        for j in range(n_el):
            ba = min(max(np.searchsorted(a_edges, ang[t, j], side="right") - 1, 0), bins - 1)
            br = min(max(np.searchsorted(r_edges, thk[t, j], side="right") - 1, 0), bins - 1)
            hd += ang[t, j]
            add_a[ba] += 1.0
            add_r[br] += 1.0
            add_h[heading_bin(hd, bins)] += 1.0
        total = max(n_t + n_el, 1.0)
        after = 0.0
        for b in range(bins):
            after += (a_target[b] - (a_counts[b] + add_a[b]) / total) ** 2
            after += (r_target[b] - (r_counts[b] + add_r[b]) / total) ** 2
            after += (h_target[b] - (h_counts[b] + add_h[b]) / total) ** 2
        gain = (before - after / bins) * omega_g * n_now / m
        qstar[t] *= np.exp(min(max(gain, -50.0), 50.0))


@njit(cache=True)
def _trace_candidates(
    cand, lens, ang, thk, xs, ys, heads, first_hit, first_out, tip, contact
):  # pragma: no cover - compiled
    """The vertices every candidate would add from the tip, its first vertex touching a
    committed branch (before leaving the image) and its first vertex outside the image."""
    x0, y0, theta, step = tip
    dist, near_branch, branch, parent, sx, sy, exempt, wrap = contact
    for t in range(cand.shape[0]):
        if cand[t] < 0:
            continue
        hx = x0
        hy = y0
        hd = theta
        first_hit[t] = -1
        first_out[t] = -1
        for j in range(lens[t]):
            hd += ang[t, j]
            hx += step * np.cos(hd)
            hy += step * np.sin(hd)
            xs[t, j] = hx
            ys[t, j] = hy
            heads[t, j] = hd
            inside, touch = _contact(dist, near_branch, hx, hy, thk[t, j], step, branch, parent, sx, sy, exempt, wrap)
            if not inside:
                if first_out[t] < 0:
                    first_out[t] = j
                continue
            if first_hit[t] < 0 and first_out[t] < 0 and touch:
                first_hit[t] = j


@njit(cache=True)
def _chord_scores(cand, lens, qstar, xs, ys, q2, tip, density):  # pragma: no cover - compiled
    """``Q** = Q* / (D + eps)`` (§4.4; divided by ``G + eps`` too with a guide) of every
    candidate: ``D`` (``G``) the largest density (guide value) at 8 points along its chord (the
    current heading for an ending candidate) up to three times its length."""
    x0, y0, theta, step = tip
    dmap, guide, use_guide, rho, eps, wrap = density
    for t in range(cand.shape[0]):
        if cand[t] < 0:
            continue
        n_el = lens[t]
        if n_el > 0:
            chord = np.arctan2(ys[t, n_el - 1] - y0, xs[t, n_el - 1] - x0)
        else:
            chord = theta
        reach = 3.0 * step * max(n_el, 1)
        dens = 0.0
        g = 0.0
        for s in range(8):
            tt = reach * (0.25 + 0.75 * s / 7.0)
            px = x0 + np.cos(chord) * tt
            py = y0 + np.sin(chord) * tt
            d, inside = _lookup(dmap, px, py, np.float32(1e6), wrap)
            if inside:
                dd = max(d, 0.0)
                dens = max(dens, np.exp(-dd * dd / (rho * rho)))
            if use_guide:
                gv, _ = _lookup(guide, px, py, np.float32(1.0), wrap)
                g = max(g, gv)
        if use_guide:
            q2[t] = qstar[t] / ((dens + eps) * (g + eps))
        else:
            q2[t] = qstar[t] / (dens + eps)


@njit(cache=True)
def _decide(
    choice, cand, qstar, lens, xs, ys, heads, first_hit, first_out, q2, decision
):  # pragma: no cover - compiled
    """The choice of :func:`extension_candidates` into ``decision``, ``choice = (c_best,
    uniforms, join_rate, join_pdf, near_tangent, wrap)``."""
    c_best, uniforms, join_rate, join_pdf, near_tangent, wrap = choice
    decision[0] = 0
    pick = _draw_best(qstar, cand, first_hit, False, c_best, uniforms[0])
    if pick < 0:
        return
    if first_hit[pick] >= 0:
        j = first_hit[pick]
        tan, ok = _lookup(near_tangent, xs[pick, j], ys[pick, j], np.float32(0.0), wrap)
        inc = abs(np.angle(np.exp(1j * (heads[pick, j] - tan))))
        inc = min(inc, np.pi - inc)
        like = 1.0
        if join_pdf.shape[0] > 0:
            like = max(join_pdf[min(int(inc / (np.pi / 2) * join_pdf.shape[0]), join_pdf.shape[0] - 1)], 0.1)
        if ok and uniforms[1] < join_rate * like:
            decision[0] = 3
            decision[1] = pick
            decision[2] = j
            return
    pick = _draw_best(q2, cand, first_hit, True, c_best, uniforms[2])
    if pick < 0:
        return
    if lens[pick] == 0:
        decision[0] = 2
        decision[1] = pick
        return
    decision[0] = 1
    decision[1] = pick
    decision[2] = lens[pick] if first_out[pick] < 0 else first_out[pick]


@njit(cache=True)
def _draw_best(score, cand, first_hit, free_only, c_best, u):  # pragma: no cover - compiled
    """Index of one of the ``c_best`` highest scores (ties: lower index), drawn with
    probability proportional to the score; -1 when there is none."""
    n = score.shape[0]
    best = np.full(c_best, -1, np.int64)
    for i in range(n):
        if cand[i] < 0 or (free_only and first_hit[i] >= 0):
            continue
        v = score[i]
        p = c_best - 1
        if best[p] >= 0 and score[best[p]] >= v:
            continue
        while p > 0 and (best[p - 1] < 0 or score[best[p - 1]] < v):
            best[p] = best[p - 1]
            p -= 1
        best[p] = i
    total = 0.0
    for p in range(c_best):
        if best[p] >= 0:
            total += max(score[best[p]], 0.0)
    if best[0] < 0:
        return -1
    if total <= 0:
        return best[0]
    target = u * total
    acc = 0.0
    for p in range(c_best):
        if best[p] >= 0:
            acc += max(score[best[p]], 0.0)
            if target < acc:
                return best[p]
    return best[0]


@njit(cache=True)
def heading_bin(heading, bins):  # pragma: no cover - compiled
    """Bin of an edge direction as an axis (modulo 180 degrees) among ``bins`` equal bins."""
    a = heading % np.pi
    return min(int(a / np.pi * bins), bins - 1)


@njit(cache=True)
def add_heading_counts(counts, headings):  # pragma: no cover - compiled
    for h in headings:
        counts[heading_bin(h, counts.shape[0])] += 1.0


@njit(cache=True)
def add_counts(counts, edges, values):  # pragma: no cover - compiled
    """Histogram counts of ``values`` on ``edges`` (outside values in the end bins)."""
    bins = counts.shape[0]
    for v in values:
        b = min(max(np.searchsorted(edges, v, side="right") - 1, 0), bins - 1)
        counts[b] += 1.0


@njit(cache=True)
def add_element_counts(
    a_counts, a_edges, r_counts, r_edges, h_counts, elements, headings
):  # pragma: no cover - compiled
    """The three histograms of §4.2 (angle, thickness, edge direction) after appending
    ``elements`` (rows of angle, thickness) along ``headings``."""
    add_counts(a_counts, a_edges, elements[:, 0])
    add_counts(r_counts, r_edges, elements[:, 1])
    add_heading_counts(h_counts, headings)


@njit(cache=True)
def push_elements(xyr, hist, n_v, n_h, elements, path, n, counts):  # pragma: no cover - compiled
    """Append the first ``n`` element rows (angle, thickness) and their vertices ``path = (xs,
    ys, heads)`` to a growing branch's buffers (``xyr`` from row ``n_v``, ``hist`` from row
    ``n_h``) and count them in the three histograms of §4.2 (``counts = (a_counts, a_edges,
    r_counts, r_edges, h_counts)``)."""
    xs, ys, heads = path
    a_counts, a_edges, r_counts, r_edges, h_counts = counts
    for j in range(n):
        xyr[n_v + j, 0] = xs[j]
        xyr[n_v + j, 1] = ys[j]
        xyr[n_v + j, 2] = elements[j, 1]
        hist[n_h + j, 0] = elements[j, 0]
        hist[n_h + j, 1] = elements[j, 1]
    add_element_counts(a_counts, a_edges, r_counts, r_edges, h_counts, elements[:n], heads[:n])


@njit(cache=True)
def polyline_length(points):  # pragma: no cover - compiled
    total = 0.0
    for i in range(1, points.shape[0]):
        total += np.hypot(points[i, 0] - points[i - 1, 0], points[i, 1] - points[i - 1, 1])
    return total


@njit(cache=True)
def vertex_turns(points):  # pragma: no cover - compiled
    """Turning angle at every vertex of a polyline (0 at both ends), in (-pi, pi]."""
    n = points.shape[0]
    va = np.zeros(n)
    for i in range(1, n - 1):
        h0 = np.arctan2(points[i, 1] - points[i - 1, 1], points[i, 0] - points[i - 1, 0])
        h1 = np.arctan2(points[i + 1, 1] - points[i, 1], points[i + 1, 0] - points[i, 0])
        d = h1 - h0
        va[i] = np.arctan2(np.sin(d), np.cos(d))
    return va


@njit(cache=True)
def furcation_margins(
    points, k, feat_mean, feat_scale, svm_w, svm_b, platt_a, platt_b, allowed
):  # pragma: no cover - compiled
    """The furcation classifier's margin at every vertex of a branch from its non-causal
    neighbourhood (§4.3: the 2k+1 turning angles and thicknesses around it, edge-replicated),
    without the furcation-distance terms, and the expected number of furcations: the sum of
    the Platt-scaled probabilities over the ``allowed`` vertices with no furcation chosen yet
    (``n-``, ``n+`` = the distances to the branch's ends)."""
    n = points.shape[0]
    va = vertex_turns(points)
    width = 2 * k + 1
    base = np.empty(n)
    expected = 0.0
    for i in range(n):
        s = svm_b
        for j in range(width):
            q = min(max(i - k + j, 0), n - 1)
            s += (va[q] - feat_mean[j]) / feat_scale[j] * svm_w[j]
            s += (points[q, 2] - feat_mean[width + j]) / feat_scale[width + j] * svm_w[width + j]
        base[i] = s
        if allowed[i]:
            s += (i - feat_mean[2 * width]) / feat_scale[2 * width] * svm_w[2 * width] + (
                n - 1 - i - feat_mean[2 * width + 1]
            ) / feat_scale[2 * width + 1] * svm_w[2 * width + 1]
            expected += 1.0 / (1.0 + np.exp(-(platt_a * s + platt_b)))
    return base, expected


@njit(cache=True)
def child_qualities(points, v, k, nb_angles, nb_thickness):  # pragma: no cover - compiled
    """Bending quality (§4.2's dist, angles times thicknesses) of every source furcation's
    non-causal neighbourhood against the 2k+1 vertices around vertex ``v`` of a branch."""
    n = points.shape[0]
    va = vertex_turns(points)
    width = 2 * k + 1
    out = np.empty(nb_angles.shape[0])
    for f in range(nb_angles.shape[0]):
        da = 0.0
        dr = 0.0
        for j in range(width):
            q = min(max(v - k + j, 0), n - 1)
            da += (nb_angles[f, j] - va[q]) ** 2
            dr += (nb_thickness[f, j] - points[q, 2]) ** 2
        out[f] = (1.0 / (np.sqrt(da) + 1.0) + 1.0) * (1.0 / (np.sqrt(dr) + 1.0) + 1.0)
    return out


@njit(cache=True)
def pick_furcations(base, allowed, d, block, feat_mean, feat_scale, svm_w):  # pragma: no cover - compiled
    """Greedy choice of ``d`` furcation vertices (§4.3): the allowed vertex of highest margin,
    whose margin includes the index distances ``n-``, ``n+`` to the nearest chosen furcation
    (or branch end) on either side; each choice blocks ``block`` vertices around it.
    ``feat_mean``, ``feat_scale``, ``svm_w`` are the classifier's last two (distance) terms."""
    n = base.shape[0]
    marks = np.zeros(n, np.bool_)
    chosen = np.empty(d, np.int64)
    n_chosen = 0
    nxt = np.empty(n, np.int64)
    for _ in range(d):
        following = n - 1  # the nearest chosen furcation after each vertex, or the end
        for i in range(n - 1, -1, -1):
            nxt[i] = following
            if marks[i]:
                following = i
        best, v = -np.inf, -1
        prev = 0  # the nearest one before, or the start
        for i in range(n):
            if allowed[i]:
                s = (
                    base[i]
                    + (i - prev - feat_mean[0]) / feat_scale[0] * svm_w[0]
                    + (nxt[i] - i - feat_mean[1]) / feat_scale[1] * svm_w[1]
                )
                if s > best:
                    best, v = s, i
            if marks[i]:
                prev = i
        if v < 0:
            break
        chosen[n_chosen] = v
        n_chosen += 1
        marks[v] = True
        for i in range(max(v - block, 0), min(v + block + 1, n)):
            allowed[i] = False
    return chosen[:n_chosen]
