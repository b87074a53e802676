"""Pictures of the bi-layer analysis: the model's layers and spectra, and the T_loc choice
sheet of guingo2017 Fig. 14."""

from __future__ import annotations

import dataclasses

import numpy as np

from barkgen._shared.arrays import as_uint8 as _u8
from barkgen.bilayer.spectra import TLOC_CHOICES


def noise_picture(noise: np.ndarray) -> np.ndarray:
    """``N`` shown around mid-grey, stretched to +-3 standard deviations."""
    spread = 3.0 * float(noise.std()) + 1e-6
    return _u8(0.5 + 0.5 * noise / spread)


def mask_picture(masks: np.ndarray) -> np.ndarray:
    """Masks as colours (one colour per noise, blended by the mask weights)."""
    from barkgen.labels.preview import label_colours

    colours = label_colours(masks.shape[2]).astype(np.float32)
    return np.clip(masks @ colours, 0, 255).astype(np.uint8)


def spectrum_picture(spectrum: np.ndarray) -> np.ndarray:
    """A spectrum's log power, zero frequency in the centre."""
    log = np.log10(np.fft.fftshift(spectrum.astype(np.float64)) ** 2 + 1e-12)
    hi = log.max()
    return _u8((log - (hi - 4.0)) / 4.0)  # four decades of dynamic range


def analysis_preview(model, synthesized: np.ndarray | None = None) -> np.ndarray:
    """Exemplar, P, N, masks and every cluster's spectrum (first PCA channel) on one sheet.

    Parameters
    ----------
    model : BilayerModel
        The analysed model.
    synthesized : ndarray, optional
        A synthesis to show as the last picture.

    Returns
    -------
    ndarray of uint8, shape (H, W, 3)
        The captioned sheet, four pictures a row.

    References
    ----------
    .. [1] guingo2017, Fig. 4.
    """
    from barkgen.labels.preview import contact_sheet

    tiles = [_u8(model.exemplar), _u8(model.structure), noise_picture(model.noise_layer), mask_picture(model.masks)]
    captions = ["exemplar I", "structure P", "noise N", "masks M_k"]
    for c in range(model.k):
        tiles.append(spectrum_picture(model.noise.spectra[c, 0]))
        captions.append(f"spectrum S_{c + 1}")
    if synthesized is not None:
        tiles.append(_u8(synthesized))
        captions.append("synthesized")
    return contact_sheet(tiles, captions, columns=4, tile_size=256)


def noise_over_structure(model, seed: int = 0) -> np.ndarray:
    """The exemplar's own structure layer ``P`` with new noise under its masks: ``P + sum_k M_k
    N_k`` with every ``N_k`` synthesized anew from its spectra (guingo2017 §5, Fig. 14's "result
    with N synthesized over the same P"), float32 ``(h, w, 3)`` in [0, 1]. It shows what T_loc put
    into the noise, with nothing else changed."""
    from barkgen._shared.arrays import unit_float

    noise = model.noise_on_torus(model.masks, np.random.default_rng([int(seed), 0xF14]))
    structure = unit_float(np.asarray(model.structure))
    if structure.ndim == 2:
        structure = np.repeat(structure[:, :, None], 3, axis=2)
    return np.clip(structure[:, :, :3] + noise, 0.0, 1.0).astype(np.float32)


def tune_sheet(exemplar: np.ndarray, options=None, *, tlocs=TLOC_CHOICES, seed: int = 0, progress=None) -> np.ndarray:
    """The T_loc choice sheet of guingo2017 Fig. 14.

    For each T_loc a row of P, N and P with new noise synthesized under its masks
    (:func:`noise_over_structure`, the same seed for all rows), so the user can pick the largest
    T_loc whose result still looks right: the paper's "result with N synthesized over the same P",
    which judges the split itself, not a synthesis of the structure too.

    Parameters
    ----------
    exemplar : ndarray
        The photo.
    options : AnalysisOptions, optional
        The analysis options (``tloc`` is replaced by each of ``tlocs``).
    tlocs : sequence of int, default TLOC_CHOICES
        The windows compared.
    seed : int, default 0
        Seed of the samples.
    progress : callable, optional
        ``progress(done, total)`` over the windows.

    Returns
    -------
    ndarray of uint8, shape (H, W, 3)
        The captioned sheet, one row per T_loc.

    References
    ----------
    .. [1] guingo2017, §5 and Fig. 14 (choosing T_loc).
    """
    from barkgen.bilayer.analysis import analyze
    from barkgen.bilayer.options import AnalysisOptions
    from barkgen.labels.preview import contact_sheet

    options = options or AnalysisOptions()
    tiles, captions = [], []
    for i, tloc in enumerate(tlocs):
        model = analyze(exemplar, dataclasses.replace(options, tloc=tloc))
        sample = noise_over_structure(model, seed)
        tiles += [_u8(model.structure), noise_picture(model.noise_layer), _u8(sample)]
        captions += [f"T_loc {tloc}: P", f"T_loc {tloc}: N", f"T_loc {tloc}: P + new N"]
        if progress:
            progress(i + 1, len(tlocs))
    return contact_sheet(tiles, captions, columns=3, tile_size=256)
