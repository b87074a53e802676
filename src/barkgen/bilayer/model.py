"""The bi-layer texture model and its on-the-fly synthesis (guingo2017 §4, eq. 6):
``I' = P' + sum_k M'_k N_k``, any window of an unbounded plane, deterministic in coordinates."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from barkgen._shared.memory import check_memory_budget
from barkgen.bilayer.options import AnalysisOptions, SynthesisOptions, as_rgb, estimate_window_memory
from barkgen.bilayer.spectra import noise_from_white, welch_power
from barkgen.bilayer.tiles import TileSet, build_tiles, default_tile_size
from barkgen.errors import InvalidInputError

#: side of the periodic noise tiles; the window reads each at four hashed offsets per
#: ``NOISE_TILE // 2`` px cell, so the noise never repeats
NOISE_TILE = 256
#: largest window one call renders (pixels), about 1.6 GB of working arrays
MAX_WINDOW_PIXELS = 1 << 28
#: side of the sample of the deformed structure whose spectrum the noise compensation measures
COMPENSATION_SAMPLE = 512


def compensated_noise(
    noise: NoiseStatistics, exemplar: np.ndarray, masks: np.ndarray, structure: np.ndarray
) -> NoiseStatistics:
    """Noise statistics topped up with the power a deformed structure lacks.

    A zoom moves the structure's power to coarser bands, and a rotation's resampling softens
    it, so the finest bands of a deformed ``P'`` are emptier than the photo's. guingo2017
    keeps fine detail under deformation by leaving the noise undeformed (§4, Fig. 10); this
    goes one step further and measures what is missing. With ``E`` the photo's power
    spectrum, ``P'`` that of a sample of the deformed structure (Welch's method) and ``N``
    the noise model's (each cluster's spectra weighted by its share of the masks), the
    deficit ``D = max(E - P' - N, 0)`` is added to every cluster's and channel's power in
    proportion to its variance, so the masks still modulate the noise and its colours keep
    their proportions. Quantile tables (histogram equalisation) are widened by the same
    factor as the deviations. A model without noise (:func:`single_layer`) is returned as is.
    """
    from scipy.ndimage import gaussian_filter

    t = noise.spectra.shape[2]
    share = masks.reshape(-1, masks.shape[2]).mean(axis=0).astype(np.float64)  # (K,)
    power = noise.spectra.astype(np.float64) ** 2  # (K, 3, T, T)
    energy = power.mean(axis=(2, 3))  # (K, 3): each channel's variance
    total = float(share @ energy.sum(axis=1))
    if total <= 0:
        return noise  # no noise layer to top up (the one-layer baseline)
    model_power = np.einsum("k,kcyx->yx", share, power)
    deficit = welch_power(exemplar, t) - welch_power(structure, t) - model_power
    deficit = gaussian_filter(np.maximum(deficit, 0.0), 1.0, mode="wrap")  # one bin of smoothing
    deficit[0, 0] = 0.0
    weights = energy / total
    spectra = np.sqrt(power + weights[:, :, None, None] * deficit[None, None])
    sigmas = np.sqrt((spectra**2).mean(axis=(2, 3)))
    widen = np.where(energy > 0, sigmas / np.sqrt(np.maximum(energy, 1e-30)), 1.0)
    quantiles = noise.quantiles.astype(np.float64) * widen[:, :, None]
    return replace(
        noise,
        spectra=spectra.astype(np.float32),
        sigmas=np.maximum(sigmas, 1e-6).astype(np.float32),
        quantiles=quantiles.astype(np.float32),
    )


@dataclass
class NoiseStatistics:
    """Per-cluster colour noise (guingo2017 §6): ``noise ≈ means[k] + bases[k] @ channels``
    with independent channels of spectra ``spectra[k, c]``, standard deviations ``sigmas``
    and optional quantile tables."""

    spectra: np.ndarray  # (K, 3, T, T)
    bases: np.ndarray  # (K, 3, 3): columns are the PCA axes
    means: np.ndarray  # (K, 3)
    sigmas: np.ndarray  # (K, 3)
    quantiles: np.ndarray  # (K, 3, Q) or (K, 3, 1) when not equalising


def _tiling(options: SynthesisOptions) -> tuple:
    """What of the options the tile set depends on."""
    return options.tile_size, options.colours, options.variants, options.blend


@dataclass
class _Synthesizer:
    tile_set: TileSet
    content: np.ndarray  # the exemplar's layers (structure, masks) the deformed contents read
    noise_tiles: np.ndarray
    hash_seed: int
    noise: NoiseStatistics  # the model's, or compensated for the deformation
    options: SynthesisOptions

    @property
    def tiles(self) -> np.ndarray:
        return self.tile_set.tiles

    def render(
        self,
        x: int,
        y: int,
        out: np.ndarray,
        structure: np.ndarray,
        noise: np.ndarray,
        fields: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> None:
        from barkgen.bilayer._kernels import render_window

        stats = self.noise
        deformation = self.options.deformation
        angle, zoom = fields if fields is not None else (np.zeros((0, 0), np.float32),) * 2
        jitter = np.array(
            [
                deformation.rotate,
                *deformation.scale,
                float(deformation.keep_vertical),
                float(deformation.active or fields is not None),
            ]
        )
        deform = (self.content, self.tile_set.centres, self.tile_set.interior, jitter, angle, zoom)
        lattice = (
            self.options.colours,
            self.options.variants,
            self.hash_seed,
            float(self.options.warp * self.tiles.shape[1]),
        )
        tables = (
            self.noise_tiles,
            self.noise_tiles.shape[2] // 2,
            stats.bases.astype(np.float64),
            stats.means.astype(np.float64),
            stats.quantiles.astype(np.float64),
            stats.sigmas.astype(np.float64),
        )
        render_window(int(y), int(x), out, (structure, noise), self.tiles, lattice, tables, deform)


@dataclass
class BilayerModel:
    """A texture as structure + spatially varying Gaussian noise (guingo2017 §4).

    Attributes
    ----------
    exemplar : ndarray of float32, shape (H, W, 3)
        The analysed image, RGB.
    structure : ndarray of float32, shape (H, W, 3)
        ``P``.
    masks : ndarray of float32, shape (H, W, K)
        ``M_k``, summing to 1.
    labels : ndarray of uint8, shape (H, W)
        The cluster of each pixel.
    noise : NoiseStatistics
        Per-cluster spectra, PCA colour bases, means, deviations, quantiles.
    options : AnalysisOptions
        The analysis parameters.
    k : int
        Number of noises.
    noise_layer : ndarray of float32, shape (H, W, 3)
        ``N = I - P`` of the exemplar.

    References
    ----------
    .. [1] guingo2017, §4, eq. 6 (synthesis ``I' = P' + sum_k M'_k N_k``).
    """

    exemplar: np.ndarray
    structure: np.ndarray
    masks: np.ndarray
    labels: np.ndarray
    noise: NoiseStatistics
    options: AnalysisOptions
    _cache: dict = field(default_factory=dict, repr=False, compare=False)

    @property
    def k(self) -> int:
        return self.masks.shape[2]

    @property
    def noise_layer(self) -> np.ndarray:
        """``N = I - P`` of the exemplar."""
        return self.exemplar - self.structure

    def _synthesizer(self, seed: int, options: SynthesisOptions) -> _Synthesizer:
        key = (int(seed), options)
        if key not in self._cache:
            if len(self._cache) >= 4:
                self._cache.pop(next(iter(self._cache)))
            tiles_seq, noise_seq, hash_seq = np.random.SeedSequence([int(seed), 0xB1]).spawn(3)
            layers = np.concatenate([self.structure, self.masks], axis=2).astype(np.float32)
            size = options.tile_size or default_tile_size(self.structure.shape[:2])
            # deformations are applied per patch by the window: one tile set serves them all
            tiling = (int(seed), options.tile_size, options.colours, options.variants, options.blend)
            known = [s.tile_set for (s_seed, o), s in self._cache.items() if (s_seed, *_tiling(o)) == tiling]
            tile_set = (
                known[0]
                if known
                else build_tiles(
                    layers,
                    np.random.default_rng(tiles_seq),
                    size=size,
                    colours=options.colours,
                    variants=options.variants,
                    blend=options.blend,
                )
            )
            period = max(NOISE_TILE, 1 << (2 * self.noise.spectra.shape[2] - 1).bit_length())  # a power of two
            hash_seed = int(hash_seq.generate_state(1, np.uint64)[0] >> np.uint64(1))
            synth = _Synthesizer(
                tile_set, layers, np.zeros((self.k, 3, period, period), np.float32), hash_seed, self.noise, options
            )
            if options.compensate and options.deformation.active:
                n = COMPENSATION_SAMPLE
                sample = np.empty((n, n, layers.shape[2]), np.float32)
                synth.render(0, 0, np.empty((n, n, 3), np.float32), sample, np.empty((n, n, 3), np.float32))
                synth.noise = compensated_noise(self.noise, self.exemplar, self.masks, sample[:, :, :3])
            rng = np.random.default_rng(noise_seq)
            for ch in range(3):  # one white noise per channel, shared by the clusters (§3.2)
                white = rng.standard_normal((period, period))
                for c in range(self.k):
                    synth.noise_tiles[c, ch] = noise_from_white(white, synth.noise.spectra[c, ch])
            self._cache[key] = synth
        return self._cache[key]

    def window(
        self,
        x: int,
        y: int,
        width: int,
        height: int,
        *,
        seed: int = 0,
        options: SynthesisOptions | None = None,
        layers: bool = False,
        flow: np.ndarray | None = None,
        flow_scale: np.ndarray | None = None,
    ):
        """Pixels ``[x, x + width) x [y, y + height)`` of the unbounded synthesized texture.

        Deterministic in coordinates: for a given seed and options, overlapping windows agree
        exactly, whatever their order or size.

        Parameters
        ----------
        x, y : int
            Top-left corner of the window on the plane (``|x|, |y| <= 2**40``).
        width, height : int
            Size of the window, > 0.
        seed : int, default 0
            Seeds the tiles, the noise and the hashes.
        options : SynthesisOptions, optional
            Tiling, warp and deformation.
        layers : bool, default False
            Also return the synthesized layers.
        flow, flow_scale : ndarray, shape (height, width), optional
            A rotation field (degrees, counter-clockwise on screen) and a zoom field (0.25-4)
            over the window, as the core engine's: each tile's exchanged content is turned and
            zoomed by the field at each pixel, on top of ``options.deformation``'s random
            per-patch draws (guingo2017 §4). Windows still agree where their fields do.

        Returns
        -------
        ndarray of float32, shape (height, width, 3), or dict
            RGB in [0, 1]; with ``layers=True`` a dict with ``texture``, ``structure``, ``masks``
            and ``noise`` (the synthesized ``P'``, ``M'_k`` and ``N'``).

        Raises
        ------
        InvalidInputError
            Non-integer or out-of-range coordinates, sizes or seed, or a window too large for one
            call.
        MemoryBudgetError
            The window would not fit ``options.max_memory`` (checked before any work).

        References
        ----------
        .. [1] guingo2017, §4 (on-the-fly synthesis).

        Examples
        --------
        >>> import barkgen
        >>> from barkgen.bilayer import analyze
        >>> model = analyze(barkgen.read_image(barkgen.sample_exemplar_path())[:64, :64])
        >>> left, right = model.window(0, 0, 64, 32, seed=3), model.window(32, 0, 64, 32, seed=3)
        >>> bool((left[:, 32:] == right[:, :32]).all())
        True
        """
        for name, v in (("x", x), ("y", y), ("width", width), ("height", height), ("seed", seed)):
            if not isinstance(v, (int, np.integer)) or isinstance(v, bool):
                raise InvalidInputError(f"window {name} must be an integer, not {v!r}")
        if width <= 0 or height <= 0:
            raise InvalidInputError(f"window size must be positive, not {width}x{height}")
        if width * height > MAX_WINDOW_PIXELS:
            raise InvalidInputError(
                f"a {width}x{height} window is too large for one call; render it in smaller windows"
            )
        if seed < 0:
            raise InvalidInputError(f"seed must be >= 0, not {seed}")
        if abs(x) > 2**40 or abs(y) > 2**40:
            raise InvalidInputError("window position out of range (|x|, |y| <= 2**40)")
        options = options or SynthesisOptions()
        check_memory_budget(
            estimate_window_memory(self.exemplar.shape[:2], (height, width), options.variants),
            options.max_memory,
            f"a {width}x{height} bi-layer window",
        )
        fields = None
        if flow is not None or flow_scale is not None:
            from barkgen.synth import check_flow

            fields = check_flow(flow, flow_scale, (height, width))
        synth = self._synthesizer(seed, options)
        n_ch = synth.tiles.shape[3]
        out = np.empty((height, width, 3), np.float32)
        structure = np.empty((height, width, n_ch) if layers else (0, 0, n_ch), np.float32)
        noise = np.empty((height, width, 3) if layers else (0, 0, 3), np.float32)
        synth.render(x, y, out, structure, noise, fields)
        if not layers:
            return out
        return {"texture": out, "structure": structure[:, :, :3], "masks": structure[:, :, 3:], "noise": noise}

    def noise_on_torus(self, masks: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """The noise layer ``sum_k M'_k N_k`` (guingo2017 eq. 6) under synthesized masks, on a
        torus of their size: each cluster's colour noise of its own spectra (random phase from
        one white noise per channel, shared by the clusters, §3.2), histogram-equalised where
        the model has quantile tables (§6), so it tiles with a tileable structure layer.

        Parameters
        ----------
        masks : ndarray, shape (H, W, K)
            ``M'_k``, e.g. the model's masks carried through a synthesis' reference map.
        rng : numpy.random.Generator
            The white noise's source.

        Returns
        -------
        ndarray of float32, shape (H, W, 3)
        """
        from scipy.special import ndtr

        h, w, k = masks.shape
        if k != self.k:
            raise InvalidInputError(f"the model has {self.k} masks, not {k}")
        stats = self.noise
        white = rng.standard_normal((3, h, w))
        n_q = stats.quantiles.shape[2]
        out = np.zeros((h, w, 3), np.float32)
        for c in range(k):
            mask = masks[:, :, c]
            if not mask.any():
                continue
            channels = np.empty((3, h, w), np.float32)
            for ch in range(3):
                v = noise_from_white(white[ch], stats.spectra[c, ch])
                if n_q > 1:  # Gaussian quantile -> the photo's quantile
                    u = ndtr(v / float(stats.sigmas[c, ch]))
                    v = np.interp(u * (n_q - 1), np.arange(n_q), stats.quantiles[c, ch]).astype(np.float32)
                channels[ch] = v
            colour = stats.means[c][None, None, :] + np.einsum("ij,jyx->yxi", stats.bases[c], channels)
            out += mask[:, :, None] * colour
        return out

    def synthesize(
        self,
        shape: tuple[int, int],
        *,
        offset: tuple[int, int] = (0, 0),
        seed: int = 0,
        options: SynthesisOptions | None = None,
    ) -> np.ndarray:
        """An ``(height, width)`` texture: the window at ``offset = (x, y)``.

        Parameters
        ----------
        shape : (int, int)
            ``(height, width)``.
        offset : (int, int), default (0, 0)
            ``(x, y)`` of the window's top-left corner.
        seed : int, default 0
            As for :meth:`window`.
        options : SynthesisOptions, optional
            As for :meth:`window`.

        Returns
        -------
        ndarray of float32, shape (height, width, 3)
        """
        return self.window(offset[0], offset[1], shape[1], shape[0], seed=seed, options=options)


def single_layer(exemplar: np.ndarray, options: AnalysisOptions | None = None) -> BilayerModel:
    """The one-layer baseline of guingo2017 Fig. 10: the whole image as structure, no noise.

    Tiled and deformed by the same synthesis, for comparisons.

    Parameters
    ----------
    exemplar : ndarray, shape (h, w) or (h, w, C)
        The photo.
    options : AnalysisOptions, optional
        Only ``spectrum_size`` is used (default ``AnalysisOptions(k=1)``).

    Returns
    -------
    BilayerModel
        One mask of ones, zero noise.

    References
    ----------
    .. [1] guingo2017, Fig. 10.
    """
    image = as_rgb(exemplar)
    options = options or AnalysisOptions(k=1)
    t = min(options.spectrum_size, (min(image.shape[:2]) // 2) * 2)
    stats = NoiseStatistics(
        spectra=np.zeros((1, 3, t, t), np.float32),
        bases=np.eye(3, dtype=np.float32)[None],
        means=np.zeros((1, 3), np.float32),
        sigmas=np.ones((1, 3), np.float32),
        quantiles=np.zeros((1, 3, 1), np.float32),
    )
    return BilayerModel(
        exemplar=image,
        structure=image.copy(),
        masks=np.ones(image.shape[:2] + (1,), np.float32),
        labels=np.zeros(image.shape[:2], np.uint8),
        noise=stats,
        options=options,
    )
