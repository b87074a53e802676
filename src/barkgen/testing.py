"""Known-answer cases and measures for testing label maps and texture-by-numbers, shared by
barkgen's tests and benchmarks and meant for anyone comparing methods (like
:mod:`numpy.testing`).

Cases: :func:`kmeans_label_map` makes a photo's label map as laitoch2018 §3.5 describes it
(non-local means denoising §3.5.2, k-means on CIELAB §3.5.3, 3x3 mode filter §3.5.4), and
:func:`shuffled_blocks` a target label map made from an exemplar's own label map cut into
blocks, shuffled, flipped and assembled to a larger size, so that a right answer (the same
arrangement of exemplar blocks) exists.

Measures of label maps: :func:`label_fractions` (label coverage), :func:`smallest_region`
(region sizes) and :func:`half_split_accuracy` (the labels follow appearance: a classifier
trained on one half of the photo predicts the other). Photos are read and cropped as the
team's compare.py does it by :func:`barkgen.io.read_centre_crop`.
"""

from __future__ import annotations

import numpy as np

#: filter strength of the non-local means denoising
DENOISE_H = 10

__all__ = ["half_split_accuracy", "kmeans_label_map", "label_fractions", "shuffled_blocks", "smallest_region"]


def kmeans_label_map(image: np.ndarray, n_labels: int, seed: int = 0) -> np.ndarray:
    """``(h, w)`` uint8 label map of an RGB uint8 image: non-local means denoising (OpenCV's
    ``fastNlMeansDenoisingColored``, as the thesis uses it), k-means on CIELAB, 3x3 mode filter;
    labels as evenly spaced grey values ordered by lightness."""
    import cv2
    from sklearn.cluster import KMeans

    smooth = cv2.fastNlMeansDenoisingColored(
        np.ascontiguousarray(image), None, h=DENOISE_H, hColor=DENOISE_H, templateWindowSize=7, searchWindowSize=21
    )
    lab = cv2.cvtColor(smooth, cv2.COLOR_RGB2LAB).reshape(-1, 3).astype(np.float32)
    km = KMeans(n_clusters=n_labels, n_init=4, random_state=seed).fit(lab)
    codes = km.labels_.reshape(image.shape[:2])
    # 3x3 mode filter: every pixel takes its neighbourhood's most common label
    votes = np.stack(
        [cv2.blur((codes == c).astype(np.float32), (3, 3), borderType=cv2.BORDER_REFLECT_101) for c in range(n_labels)]
    )
    codes = votes.argmax(axis=0)
    order = np.argsort(km.cluster_centers_[:, 0])  # darkest label first
    rank = np.empty(n_labels, np.int64)
    rank[order] = np.arange(n_labels)
    grey = np.round(np.linspace(0, 255, n_labels)).astype(np.uint8)
    return grey[rank[codes]]


def shuffled_blocks(label_map: np.ndarray, size: int, block: int = 64, seed: int = 0, flip: bool = True) -> np.ndarray:
    """A ``size x size`` target label map: the map cut into ``block``-px blocks, shuffled,
    each flipped at random, and assembled (blocks reused once all have been placed)."""
    rng = np.random.default_rng(seed)
    h, w = label_map.shape[:2]
    blocks = [
        label_map[y : y + block, x : x + block]
        for y in range(0, h - block + 1, block)
        for x in range(0, w - block + 1, block)
    ]
    n = size // block
    out = np.empty((n * block, n * block) + label_map.shape[2:], label_map.dtype)
    order: list[int] = []
    for i in range(n * n):
        if not order:
            order = list(rng.permutation(len(blocks)))
        b = blocks[order.pop()]
        fy, fx = rng.random(2) < 0.5
        if flip and fy:
            b = b[::-1]
        if flip and fx:
            b = b[:, ::-1]
        y, x = divmod(i, n)
        out[y * block : (y + 1) * block, x * block : (x + 1) * block] = b
    return out


def label_fractions(label_map: np.ndarray) -> np.ndarray:
    """Fraction of the pixels of each label (sorted grey values)."""
    _, counts = np.unique(label_map, return_counts=True)
    return counts / label_map.size


def smallest_region(label_map: np.ndarray) -> int:
    """Pixels of the smallest 8-connected region of one label."""
    import cv2

    smallest = label_map.size
    for v in np.unique(label_map):
        _, _, stats, _ = cv2.connectedComponentsWithStats((label_map == v).astype(np.uint8), connectivity=8)
        smallest = min(smallest, int(stats[1:, cv2.CC_STAT_AREA].min()))
    return smallest


def _features(rgb_u8: np.ndarray) -> np.ndarray:
    """Per-pixel CIELAB, its 7x7 mean and standard deviation, and L's over 15x15 (the
    features of the team's texeval label classifier)."""
    import cv2

    lab = cv2.cvtColor(rgb_u8, cv2.COLOR_RGB2LAB).astype(np.float32)
    feats: list[np.ndarray] = [lab[..., c] for c in range(3)]
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
    clf = RandomForestClassifier(n_estimators=40, max_depth=18, min_samples_leaf=3, n_jobs=-1, random_state=seed).fit(
        x_train[pick], y_train[pick]
    )
    x_test = feats[:, half:].reshape(-1, feats.shape[2])
    return float((clf.predict(x_test) == label_map[:, half:].ravel()).mean())
