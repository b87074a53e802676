"""A material set of any size written as its windows are finished (issue 69, "bark at any
size"): the files :func:`barkgen.io.encode_material` writes for the output's set, band by band,
never a map of the output's size in memory.

The set's maps are resolved window by window (:func:`barkgen.pipeline.windowed.material_in_windows`:
the maps carried through the reference map, laitoch2018 §3.3.1, the height and its normals and
AO, wang2003 §3.4), and each map's file pixels are the very encoding of each pixel's values
(:func:`barkgen.material.presets.preset_images`), so a row of window cores (a band of ``window``
rows across the output) gives its band of every file: written at once to one
:class:`barkgen.io.PngStream` per file (per UDIM tile of a file).

Only the displacement waits: its 16-bit file holds the height rescaled from the output's lowest
to its highest point, known after the last window. The bands' heights (and the other channels of
any image that packs the displacement with other maps) are spilled to a raw file on disk as they
come, and read back band by band once the range is known, for the displacement's files and its
EXR. ``NAME.json``, ``NAME_blender.py`` and ``NAME.mtlx`` are made from an outline of the set
(:class:`OutputOutline`: the whole output's size, its height range, the source set's record)
as :func:`barkgen.io.encode_material` makes them from the whole set.
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
import tempfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from barkgen._shared.canvas import Canvas
from barkgen._shared.memory import give_back_freed_memory
from barkgen.errors import InvalidInputError
from barkgen.io.udim import UdimGrid, udim_file_name, udim_grid, udim_number
from barkgen.material.materialset import MaterialSet
from barkgen.pipeline.windowed import (
    MATERIAL_HALO,
    WINDOW,
    HeightRange,
    References,
    WindowMaps,
    material_in_windows,
    resolve_windows,
)

if TYPE_CHECKING:
    from barkgen.io.streaming import ExrStream, PngStream

#: a stream's staged ``(temporary, target)`` pairs (:mod:`barkgen.io.staging`)
Staged = list[tuple[str, Path]]


@dataclass
class OutputOutline(MaterialSet):
    """A stand-in for the whole output's :class:`~barkgen.material.MaterialSet` where only its
    record is wanted (``NAME.json``, ``NAME_blender.py``, ``NAME.mtlx``): a window core's set
    (its light, pixel size, scan record, which maps it has) whose ``height`` is the output's
    lowest and highest point alone, ``[[low, high]]``, so that :attr:`depth`, :attr:`midlevel`
    and :meth:`metadata` compute them as the whole set does, and whose :attr:`shape` is the
    output's. Its maps are a pixel each: never encode its images.

    Attributes
    ----------
    output_shape : (int, int)
        The whole output's ``(h, w)``.
    """

    output_shape: tuple[int, int] = (0, 0)

    @property
    def shape(self) -> tuple[int, int]:
        """The whole output's ``(h, w)``."""
        return self.output_shape


def output_outline(core: MaterialSet, shape: tuple[int, int], height_range: HeightRange) -> OutputOutline:
    """The :class:`OutputOutline` of an output of ``shape`` from one of its window cores'
    sets and the output's gathered ``height_range``."""
    arrays: dict[str, Any] = {
        f.name: np.ascontiguousarray(getattr(core, f.name)[:1, :1])
        for f in dataclasses.fields(MaterialSet)
        if isinstance(getattr(core, f.name), np.ndarray)
    }
    arrays["height"] = np.array([[height_range.low, height_range.high]], dtype=core.height.dtype)
    kept = {f.name: getattr(core, f.name) for f in dataclasses.fields(MaterialSet) if f.name not in arrays}
    return OutputOutline(**kept, **arrays, output_shape=(int(shape[0]), int(shape[1])))


def whole_displacement(outline: MaterialSet, height: np.ndarray) -> np.ndarray:
    """Rows of the output's ``height`` normalised as the whole set's
    :meth:`~barkgen.material.MaterialSet.displacement` normalises them (by the output's lowest
    point and :attr:`OutputOutline.depth`), float64 in [0, 1]."""
    h = np.asarray(height).astype(np.float64)
    depth = outline.depth
    return (h - float(outline.height.min())) / depth if depth > 0 else np.full(h.shape, 0.5)


@dataclass(frozen=True)
class DisplacementPlan:
    """Which of a preset's images hold the displacement, found by encoding a two-pixel set
    twice, its height rising and falling (:func:`displacement_plan`).

    Attributes
    ----------
    alone : tuple of str
        Images that are the 16-bit displacement and nothing else.
    packed : dict of str to tuple of int
        Images that pack the displacement (16-bit) with other maps: the channels holding it.
    """

    alone: tuple[str, ...]
    packed: dict[str, tuple[int, ...]]


def displacement_plan(core: MaterialSet, name: str, preset: str) -> DisplacementPlan:
    """Find the images of ``preset`` that hold the displacement (and its channels), so that
    the first pass writes the rest and the second these (a preset packing it in an 8-bit image,
    or altering it, is refused: it could not be written from the spilled height)."""
    from barkgen.material.presets import preset_images

    def probe(heights: list[float]) -> dict[str, np.ndarray]:
        pair: dict[str, Any] = {
            f.name: np.repeat(np.asarray(getattr(core, f.name))[:1, :1], 2, axis=1)
            for f in dataclasses.fields(MaterialSet)
            if isinstance(getattr(core, f.name), np.ndarray)
        }
        pair["height"] = np.array([heights], np.float32)
        return preset_images(dataclasses.replace(core, **pair), name, preset)

    rising, falling = probe([0.0, 1.0]), probe([1.0, 0.0])
    alone, packed = [], {}
    for file, pixels in rising.items():
        up = pixels.reshape(1, 2, -1)
        changed = tuple(int(c) for c in np.flatnonzero((up != falling[file].reshape(1, 2, -1)).any(axis=(0, 1))))
        if not changed:
            continue
        if pixels.dtype != np.uint16 or any(up[0, 0, c] != 0 or up[0, 1, c] != 65535 for c in changed):
            raise InvalidInputError(f"{file} holds the displacement otherwise than as 16-bit values: cannot stream it")
        if len(changed) == up.shape[2]:
            alone.append(file)
        else:
            packed[file] = changed
    return DisplacementPlan(tuple(alone), packed)


class SpillFile:
    """Bands of one array kind kept on disk until the second pass: appended with
    ``os.write``, read back with ``os.pread`` (raw bytes, C order) in a file of ``folder``."""

    def __init__(self, folder: str, kind: str) -> None:
        self.fd = os.open(os.path.join(folder, f"{kind}.raw"), os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o600)
        self.size = 0
        self.bands: list[tuple[int, tuple[int, ...], np.dtype]] = []

    def append(self, band: np.ndarray) -> None:
        """Keep ``band`` (any shape and dtype) after the bands before it."""
        data = np.ascontiguousarray(band).data.cast("B")
        self.bands.append((self.size, band.shape, band.dtype))
        written = 0
        while written < len(data):
            written += os.write(self.fd, data[written:])
        self.size += len(data)

    def read(self, index: int) -> np.ndarray:
        """The ``index``-th band appended."""
        offset, shape, dtype = self.bands[index]
        nbytes = int(np.prod(shape)) * dtype.itemsize
        buffer = bytearray(nbytes)
        done = 0
        while done < nbytes:
            piece = os.pread(self.fd, nbytes - done, offset + done)
            if not piece:
                raise OSError(f"the spilled {dtype} band {index} ends early")
            buffer[done : done + len(piece)] = piece
            done += len(piece)
        return np.frombuffer(buffer, dtype).reshape(shape)

    def close(self) -> None:
        os.close(self.fd)


class TiledFile:
    """One image of the set, written band by band top to bottom: to one stream, or cut into
    the UDIM tiles of ``grid`` (a band spans the tiles along x; a tile's stream opens at its
    first row and is closed at its last; tile numbers count rows up, :mod:`barkgen.io.udim`)."""

    def __init__(self, folder: Path, file: str, shape: tuple[int, int], grid: UdimGrid | None, staged: Staged) -> None:
        self.folder, self.file, self.grid, self.staged = folder, file, grid, staged
        self.tile = grid.tile if grid is not None else (int(shape[0]), int(shape[1]))
        self.open: dict[str, PngStream | ExrStream] = {}
        self.hashes: dict[str, str] = {}
        self.top = 0

    def name(self, row: int, column: int) -> str:
        """The file name of the tile ``row`` down and ``column`` across (the file's own without
        a grid)."""
        if self.grid is None:
            return self.file
        return udim_file_name(self.file, udim_number(column, self.grid.rows - 1 - row))

    def write(self, band: np.ndarray) -> None:
        """The next rows of the whole image, ``(n, W[, C])``."""
        from barkgen.io.streaming import ExrStream, PngStream

        tile_h, tile_w = self.tile
        start, stop = self.top, self.top + len(band)
        for row in range(start // tile_h, -(-stop // tile_h)):
            rows = slice(max(start, row * tile_h) - start, min(stop, (row + 1) * tile_h) - start)
            for column in range(band.shape[1] // tile_w):
                name = self.name(row, column)
                stream = self.open.get(name)
                if stream is None:  # (a tile's first rows)
                    target = self.folder / name
                    if name.endswith(".exr"):
                        stream = ExrStream(target, tile_w, tile_h, staged=self.staged)
                    else:
                        channels = 1 if band.ndim == 2 else band.shape[2]
                        bits = 16 if band.dtype == np.uint16 else 8
                        stream = PngStream(target, tile_w, tile_h, channels=channels, bits=bits, staged=self.staged)
                    self.open[name] = stream
                stream.write(band[rows, column * tile_w : (column + 1) * tile_w])
                if stream.rows_written == tile_h:
                    stream.close()
                    assert stream.sha256 is not None
                    self.hashes[name] = stream.sha256
                    del self.open[name]
        self.top = stop

    def abort(self) -> None:
        """Drop every stream still open (their temporaries removed)."""
        for stream in self.open.values():
            stream.abort()
        self.open.clear()


@dataclass
class BandBuffer:
    """One band of the output (a row of window cores, ``rows``, ``width`` px across) of every
    image of the preset and of the height, filled core by core as the cores come
    (:meth:`add`): a pixel's file value depends on its own values alone
    (:func:`~barkgen.material.presets.preset_images`), so the cores' pixels laid side by side
    are the band of the whole set's images; the displacement's hold the cores' own
    normalisation (the second pass rewrites them).

    Attributes
    ----------
    rows : slice
        The band's rows in the output.
    width : int
        The output's width.
    images : dict of str to ndarray
        File name -> the band's pixels.
    heights : ndarray of float32 or None
        The band's height (px).
    """

    rows: slice
    width: int
    images: dict[str, np.ndarray] = dataclasses.field(default_factory=dict)
    heights: np.ndarray | None = None

    def add(self, columns: slice, images: dict[str, np.ndarray], height: np.ndarray) -> None:
        """A core's encoded ``images`` and ``height`` at ``columns``."""
        n = self.rows.stop - self.rows.start
        for file, pixels in images.items():
            if file not in self.images:
                self.images[file] = np.empty((n, self.width) + pixels.shape[2:], pixels.dtype)
            self.images[file][:, columns] = pixels
        if self.heights is None:
            self.heights = np.empty((n, self.width), np.float32)
        self.heights[:, columns] = height


def write_material_streamed(
    source: MaterialSet,
    references: References,
    canvas: Canvas,
    folder: str | os.PathLike,
    /,
    name: str,
    preset: str = "ambientcg",
    *,
    blend: str = "gradient",
    width_m: float | None = None,
    exr_height: bool = False,
    udim: tuple[int, int] | None = None,
    window: int = WINDOW,
    halo: int = MATERIAL_HALO,
    spill_folder: str | os.PathLike | None = None,
    progress: Callable[[int, int], None] | None = None,
    illumination: str | None = None,
    staged: Staged | None = None,
    **metadata,
) -> dict[str, str]:
    """Write the output's material set into ``folder`` as its windows are finished.

    The files are those :func:`barkgen.io.encode_material` encodes for
    ``transfer_material(source, references, canvas, blend=blend).with_width_m(width_m)`` (the
    set ``generate`` makes, :func:`barkgen.pipeline.materials.output_material`), their pixels
    within a last bit of the whole solve's (:mod:`barkgen.pipeline.windowed`), but memory
    bounded by a band of ``window`` rows across the output: each row of window cores is
    encoded and written to its files at once; the heights wait on disk for the output's height
    range, then the displacement is written from them (issue 69; laitoch2018 §3.3.1, the maps
    carried through the reference map; wang2003 §3.4, the height field and its displacement).

    Parameters
    ----------
    source : MaterialSet
        The photo's set, as ``generate`` carries it.
    references : ndarray or callable
        The output's reference map (:data:`barkgen.pipeline.windowed.References`).
    canvas : Canvas
        The output's (``shape``, ``tile``, the resolved ``exemplar_wrap``).
    folder : str or PathLike
        Where the files go (made if missing).
    name : str
        The set's ``NAME`` (:func:`barkgen.io.check_material_name`).
    preset : {"ambientcg", "blender", "unreal", "unity", "gltf"}, default "ambientcg"
        The engine's names and packing, as :func:`barkgen.io.encode_material`'s.
    blend : {"gradient", "none"}, default "gradient"
        How the colour is carried (``GenerateOptions.blend``).
    width_m : float, optional
        The set's real-world width in metres (``GenerateOptions.width_m``).
    exr_height : bool, default False
        Also ``NAME_Displacement.exr`` (float32).
    udim : (int, int), optional
        ``(columns, rows)`` of UDIM tiles, as :func:`barkgen.io.encode_material`'s.
    window : int, default WINDOW
        Side of a window's core in px: a band is this many rows.
    halo : int, default MATERIAL_HALO
        Px resolved round a core.
    spill_folder : str or PathLike, optional
        Where the heights wait (a temporary folder made there and removed after): 4 bytes an
        output pixel. Default: beside the files, in ``folder``.
    progress : callable, optional
        Called ``progress(windows_done, windows)`` after each window.
    illumination : str, optional
        Also the photo's broad light as carried to the output, under this file name
        (:func:`barkgen.material.encode_illumination`; whole, never in UDIM tiles), when the set
        has it.
    staged : list, optional
        The caller's staged files (:mod:`barkgen.io.staging`): the set's are added to them and
        left for the caller to commit with its own; on an error here, the set's are discarded.
        Default: the set's files are committed at the end.
    **metadata
        Added to ``NAME.json``, as :func:`barkgen.io.encode_material`'s.

    Returns
    -------
    dict of str to str
        Every file written -> its SHA-256 (hex).

    Raises
    ------
    InvalidInputError
        A bad name, preset or UDIM grid, or a canvas the windows do not take. On any error
        (an interrupt included) no file of the set is left: each is written to a staged
        temporary, all renamed into place after the last.
    """
    from barkgen._shared.extras import require_extra
    from barkgen.io.material import check_material_name
    from barkgen.io.staging import commit_staged, discard_staged
    from barkgen.material.presets import check_preset

    check_material_name(name)
    check_preset(preset)
    if exr_height:  # (refused before any work, not at the second pass)
        require_extra("exr", "32-bit EXR maps")
    if preset == "blender":
        require_extra("materialx", "the Blender preset's MaterialX document")
    grid = None if udim is None else udim_grid(canvas.shape, udim)
    folder = Path(folder)
    mine: Staged = []
    writers: dict[str, TiledFile] = {}
    spills: dict[str, SpillFile] = {}
    target = (folder, grid, mine, writers, canvas.shape, illumination)
    try:
        missing = [f for f in (folder, *folder.parents) if not f.exists()]
        folder.mkdir(parents=True, exist_ok=True)
        mine.extend(("", f) for f in reversed(missing))  # made here: removed again on a failure
        with tempfile.TemporaryDirectory(prefix=".barkgen-spill-", dir=spill_folder or folder) as spill_dir:
            try:
                windows = material_in_windows(source, references, canvas, window=window, halo=halo, blend=blend)
                total = len(resolve_windows(canvas.shape, window, halo, canvas.tile))
                outline, images, plan = _first_pass(windows, spill_dir, spills, name, preset, target, total, progress)
                whole = outline.with_width_m(width_m)  # (an outline still: its shape the output's)
                _second_pass(whole, spills, plan, exr_height, name, target)
            finally:
                for spill in spills.values():
                    spill.close()
        hashes = {file: digest for writer in writers.values() for file, digest in writer.hashes.items()}
        written = sorted(file for file in hashes if file != illumination)
        hashes.update(_record_files(whole, name, preset, images, written, grid, folder, mine, metadata))
        if staged is None:
            commit_staged(mine)
    except BaseException:
        for writer in writers.values():
            writer.abort()
        discard_staged(mine)
        raise
    if staged is not None:
        staged.extend(mine)
    return hashes


def _writer(target: tuple, file: str) -> TiledFile:
    """The :class:`TiledFile` of ``file`` (made at its first band): ``target`` is
    ``(folder, grid, staged, writers, the output's shape, the illumination's file)``; the
    illumination is a run's file, never in tiles."""
    folder, grid, staged, writers, shape, illumination = target
    if file not in writers:
        writers[file] = TiledFile(folder, file, shape, None if file == illumination else grid, staged)
    return writers[file]


def _first_pass(
    windows: Iterator[WindowMaps],
    spill_dir: str,
    spills: dict[str, SpillFile],
    name: str,
    preset: str,
    target: tuple,
    total: int,
    progress: Callable[[int, int], None] | None,
) -> tuple[OutputOutline, list[str], DisplacementPlan]:
    """Every band's images written but the displacement's, core by core (no core kept once
    encoded); its heights (and the other channels of an image packing the displacement)
    spilled into ``spills`` (made here). Returns the output's outline, the preset's image
    names and the :class:`DisplacementPlan`."""
    from barkgen.material.illumination import encode_illumination
    from barkgen.material.presets import preset_images

    height_range, first, plan, band, done = HeightRange(), None, None, None, 0
    shape, illumination = target[4], target[5]
    for maps in windows:
        material = maps.material
        assert material is not None
        if first is None:
            first = output_outline(material, shape, HeightRange())  # (a pixel of each map: kept)
            plan = displacement_plan(material, name, preset)
            for i, kind in enumerate(["height", *plan.packed]):
                spills[kind] = SpillFile(spill_dir, f"spill{i}")
        assert plan is not None
        if band is not None and band.rows != maps.target[0]:
            write_band(band, plan, spills, target)
        if band is None or band.rows != maps.target[0]:
            band = BandBuffer(maps.target[0], int(shape[1]))
        images = preset_images(material, name, preset)
        if illumination is not None and material.illumination is not None:
            images[illumination] = encode_illumination(material.illumination)
        band.add(maps.target[1], images, material.height)
        height_range = height_range.add(material.height)
        del maps, material  # (not held while the next window is solved)
        give_back_freed_memory()
        done += 1
        if progress is not None:
            progress(done, total)
    if first is None or plan is None or band is None:
        raise InvalidInputError("the output has no windows")
    write_band(band, plan, spills, target)
    return output_outline(first, shape, height_range), sorted(set(band.images) - {illumination}), plan


def write_band(band: BandBuffer, plan: DisplacementPlan, spills: dict[str, SpillFile], target: tuple) -> None:
    """A finished band's images written to their files but the displacement's; its heights (and
    the images packing the displacement) spilled for the second pass."""
    assert band.heights is not None
    spills["height"].append(band.heights)
    for file, pixels in band.images.items():
        if file in plan.packed:
            spills[file].append(pixels)
        elif file not in plan.alone:
            _writer(target, file).write(pixels)


def _second_pass(
    outline: MaterialSet,
    spills: dict[str, SpillFile],
    plan: DisplacementPlan,
    exr_height: bool,
    name: str,
    target: tuple,
) -> None:
    """The displacement's images (and its EXR) written band by band from the spilled heights,
    normalised by the output's range as the whole set's
    :meth:`~barkgen.material.MaterialSet.displacement`."""
    for index in range(len(spills["height"].bands)):
        displacement = whole_displacement(outline, spills["height"].read(index))
        encoded = np.round(displacement * 65535).astype(np.uint16)
        for file in plan.alone:
            _writer(target, file).write(encoded)
        for file, channels in plan.packed.items():
            pixels = np.array(spills[file].read(index))
            pixels[..., list(channels)] = encoded[..., None]
            _writer(target, file).write(pixels)
        if exr_height:
            _writer(target, f"{name}_Displacement.exr").write(displacement.astype(np.float32))


def _record_files(
    outline: MaterialSet,
    name: str,
    preset: str,
    images: list[str],
    written: list[str],
    grid: UdimGrid | None,
    folder: Path,
    staged: Staged,
    metadata: dict,
) -> dict[str, str]:
    """``NAME.json``, ``NAME_blender.py`` (and ``NAME.mtlx``) staged as
    :func:`barkgen.io.encode_material` makes them for the whole set (its ``outline`` here),
    ``written`` the image files; returns their SHA-256."""
    from barkgen.io.material import encode_set_records
    from barkgen.io.staging import stage_files

    files = encode_set_records(outline, name, preset, images, written, udim=grid, **metadata)
    stage_files(folder, files, staged)
    return {file: hashlib.sha256(data).hexdigest() for file, data in files.items()}
