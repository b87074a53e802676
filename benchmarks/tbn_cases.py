"""Texture-by-numbers test cases with a known answer (issue 3's acceptance set).

For a 256x256 exemplar: its 2- and 3-label maps as laitoch2018 §3.5 makes them (non-local means
denoising §3.5.2, k-means on CIELAB §3.5.3, 3x3 mode filter §3.5.4), and target label maps made from the exemplar's own label map
cut into blocks, shuffled, flipped and assembled to a larger size, so that a right answer (the
same arrangement of exemplar blocks) exists.

Used by ``benchmarks/bench_tbn.py`` and the tests; needs scikit-learn (a test dependency).
"""

from __future__ import annotations

import numpy as np

#: filter strength of the non-local means denoising
DENOISE_H = 10


def centre_crop(path, size: int) -> np.ndarray:
    """RGB uint8 centre crop of an image file, short side resized to ``size`` first (as the
    team's compare.py prepares exemplars)."""
    from PIL import Image

    im = Image.open(path).convert("RGB")
    w, h = im.size
    s = size / min(w, h)
    im = im.resize((max(size, round(w * s)), max(size, round(h * s))), Image.LANCZOS)
    w, h = im.size
    left, top = (w - size) // 2, (h - size) // 2
    return np.asarray(im.crop((left, top, left + size, top + size)))


def kmeans_label_map(image: np.ndarray, n_labels: int, seed: int = 0) -> np.ndarray:
    """``(h, w)`` uint8 label map of an RGB uint8 image: non-local means denoising (OpenCV's
    ``fastNlMeansDenoisingColored``, as the thesis uses it), k-means on CIELAB, 3x3 mode filter;
    labels as evenly spaced grey values ordered by lightness."""
    import cv2
    from sklearn.cluster import KMeans

    smooth = cv2.fastNlMeansDenoisingColored(np.ascontiguousarray(image), None, h=DENOISE_H,
                                             hColor=DENOISE_H, templateWindowSize=7,
                                             searchWindowSize=21)
    lab = cv2.cvtColor(smooth, cv2.COLOR_RGB2LAB).reshape(-1, 3).astype(np.float32)
    km = KMeans(n_clusters=n_labels, n_init=4, random_state=seed).fit(lab)
    codes = km.labels_.reshape(image.shape[:2])
    # 3x3 mode filter: every pixel takes its neighbourhood's most common label
    votes = np.stack([cv2.blur((codes == c).astype(np.float32), (3, 3),
                               borderType=cv2.BORDER_REFLECT_101) for c in range(n_labels)])
    codes = votes.argmax(axis=0)
    order = np.argsort(km.cluster_centers_[:, 0])  # darkest label first
    rank = np.empty(n_labels, np.int64)
    rank[order] = np.arange(n_labels)
    grey = np.round(np.linspace(0, 255, n_labels)).astype(np.uint8)
    return grey[rank[codes]]


def shuffled_blocks(label_map: np.ndarray, size: int, block: int = 64, seed: int = 0,
                    flip: bool = True) -> np.ndarray:
    """A ``size x size`` target label map: the map cut into ``block``-px blocks, shuffled,
    each flipped at random, and assembled (blocks reused once all have been placed)."""
    rng = np.random.default_rng(seed)
    h, w = label_map.shape[:2]
    blocks = [label_map[y:y + block, x:x + block]
              for y in range(0, h - block + 1, block) for x in range(0, w - block + 1, block)]
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
        out[y * block:(y + 1) * block, x * block:(x + 1) * block] = b
    return out
