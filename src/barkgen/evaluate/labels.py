"""How a result follows its target label map, from its reference map: the share of a label's
pixels filled from that label of the photo, and for a label drawn as thin lines (a crack
network), whether the copied lines run the way the target's run."""

from __future__ import annotations

import numpy as np

from barkgen.errors import InvalidInputError


def _label_values(name: str, labels: np.ndarray, value) -> np.ndarray:
    """``(H, W)`` bool: the pixels of ``labels`` (grey or colour) that are ``value``."""
    arr = np.asarray(labels)
    if arr.ndim == 2:
        return arr == value
    if arr.ndim == 3:
        return (arr == np.broadcast_to(np.asarray(value), arr.shape[2:])).all(axis=2)
    raise InvalidInputError(f"{name} must be an (H, W) or (H, W, C) label map, not shape {arr.shape}")


def _copied(exemplar_labels, target_labels, references, value) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The exemplar's and the target's ``value`` masks and the exemplar mask read through the
    references (checked against both maps)."""
    source = _label_values("exemplar_labels", exemplar_labels, value)
    target = _label_values("target_labels", target_labels, value)
    refs = np.asarray(references)
    if refs.shape != target.shape + (2,) or not np.issubdtype(refs.dtype, np.integer):
        raise InvalidInputError(f"references must be an integer array of shape {target.shape + (2,)}")
    ry, rx = refs[..., 0], refs[..., 1]
    if ry.min() < 0 or rx.min() < 0 or ry.max() >= source.shape[0] or rx.max() >= source.shape[1]:
        raise InvalidInputError("the reference map points outside the exemplar label map")
    return source, target, source[ry, rx]


def label_share(exemplar_labels: np.ndarray, target_labels: np.ndarray, references: np.ndarray, value) -> float:
    """Of the target's pixels of label ``value``, the share copied from pixels of that label in
    the exemplar (the crack share of a grown crack network: its pixels filled with the photo's
    cracks). NaN when the target has no such pixel."""
    _, target, copied = _copied(exemplar_labels, target_labels, references, value)
    return float(copied[target].mean()) if target.any() else float("nan")


def direction_agreement(
    exemplar_labels: np.ndarray,
    target_labels: np.ndarray,
    references: np.ndarray,
    value,
    *,
    tile: bool = False,
) -> float:
    """Whether the lines of label ``value`` run, where they were copied from, the way the
    target's lines run where they were copied to: the mean cosine of twice the angle between
    the two directions (each the doubled angle of its map's structure tensor,
    :func:`barkgen.synth.thin_label_channels`), weighted by how clear both
    are, over the target's pixels of that label. 1: parallel everywhere; 0: unrelated; -1:
    crosswise. ``tile``: the target wraps round. NaN when no pixel has both directions."""
    from barkgen.synth import thin_label_channels

    source, target, _ = _copied(exemplar_labels, target_labels, references, value)
    one = np.ones(1, np.int32)
    ds = thin_label_channels(source.astype(np.int32), one)[..., 1:]
    dt = thin_label_channels(target.astype(np.int32), one, wrap=tile)[..., 1:]
    refs = np.asarray(references)
    ds = ds[refs[..., 0], refs[..., 1]][target]
    dt = dt[target]
    weight = np.linalg.norm(ds, axis=1) * np.linalg.norm(dt, axis=1)
    if not (weight > 0).any():
        return float("nan")
    return float((ds * dt).sum(axis=1).sum() / weight.sum())
