"""Measures of label maps (issue 4's acceptance): region sizes, label coverage, and whether the
labels follow appearance (a classifier trained on one half of the photo predicts the other).

Used by ``benchmarks/bench_labels.py`` and the tests; needs scikit-learn.
"""

from __future__ import annotations

import numpy as np


def label_fractions(label_map: np.ndarray) -> np.ndarray:
    """Fraction of the pixels of each label (sorted grey values)."""
    _, counts = np.unique(label_map, return_counts=True)
    return counts / label_map.size


def smallest_region(label_map: np.ndarray) -> int:
    """Pixels of the smallest 8-connected region of one label."""
    import cv2

    smallest = label_map.size
    for v in np.unique(label_map):
        _, _, stats, _ = cv2.connectedComponentsWithStats((label_map == v).astype(np.uint8),
                                                          connectivity=8)
        smallest = min(smallest, int(stats[1:, cv2.CC_STAT_AREA].min()))
    return smallest


def _features(rgb_u8: np.ndarray) -> np.ndarray:
    """Per-pixel CIELAB, its 7x7 mean and standard deviation, and L's over 15x15 (the
    features of the team's texeval label classifier)."""
    import cv2

    lab = cv2.cvtColor(rgb_u8, cv2.COLOR_RGB2LAB).astype(np.float32)
    feats = [lab[..., c] for c in range(3)]
    for c, size in ((0, 7), (1, 7), (2, 7), (0, 15)):
        m = cv2.blur(lab[..., c], (size, size))
        m2 = cv2.blur(lab[..., c] ** 2, (size, size))
        feats += [m, np.sqrt(np.maximum(m2 - m * m, 0))]
    return np.stack(feats, -1)


def half_split_accuracy(image: np.ndarray, label_map: np.ndarray, seed: int = 0) -> float:
    """Accuracy on the right half of a random forest trained on the left half (the labels
    follow appearance, not noise, if it is high)."""
    from sklearn.ensemble import RandomForestClassifier

    rgb = np.asarray(image)
    if rgb.dtype == np.uint16:
        rgb = (rgb >> 8).astype(np.uint8)
    if rgb.ndim == 2:
        rgb = np.repeat(rgb[:, :, None], 3, axis=2)
    feats = _features(np.ascontiguousarray(rgb[..., :3]))
    half = rgb.shape[1] // 2
    x_train = feats[:, :half].reshape(-1, feats.shape[2])
    y_train = label_map[:, :half].ravel()
    rng = np.random.default_rng(seed)
    pick = rng.choice(len(x_train), min(len(x_train), 40_000), replace=False)
    clf = RandomForestClassifier(n_estimators=40, max_depth=18, min_samples_leaf=3, n_jobs=-1,
                                 random_state=seed).fit(x_train[pick], y_train[pick])
    x_test = feats[:, half:].reshape(-1, feats.shape[2])
    return float((clf.predict(x_test) == label_map[:, half:].ravel()).mean())
