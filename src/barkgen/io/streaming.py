"""Images written band by band as they are finished (issue 69: a 16384² output is never held
whole, nor its encoded bytes): :class:`PngStream` filters and deflates each band of rows as it
comes, :class:`ExrStream` hands each band of scanlines to OpenEXR.

Both keep barkgen's no-loss rules (:mod:`barkgen.io.staging`): the file is written to a
temporary beside its target, named as :data:`barkgen.io.staging.TEMPORARY_NAME` says, synced
to disk and renamed into place only when its last row is in; an error part-way (a band of the
wrong shape, an interrupt, a full disk) removes the temporary and leaves the target as it was.
Given a ``staged`` list, a stream renames nothing: it appends ``(temporary, target)`` to the
list when it opens, like :func:`barkgen.io.staging.stage_files`, and the caller renames a whole
set at once with :func:`barkgen.io.staging.commit_staged` (or drops it with
:func:`barkgen.io.staging.discard_staged`).

The PNG's rows are filtered as libpng filters them: each row with the filter type (None, Sub,
Up, Average or Paeth: the PNG specification, ISO/IEC 15948 / W3C PNG Second Edition, §9 Filtering)
whose output has the least sum of absolute values read as signed bytes; whole bands at a time in
numpy, one deflate stream over the file, IDAT chunks of at most :data:`IDAT_BYTES`.
"""

from __future__ import annotations

import hashlib
import os
import struct
import tempfile
import zlib
from pathlib import Path
from typing import IO, Any

import numpy as np

from barkgen.errors import InvalidInputError
from barkgen.io.images import _png_text_chunk
from barkgen.io.staging import commit_staged, current_umask, discard_staged, remove_stale_temporaries

#: the PNG signature (the file's first 8 bytes)
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
#: the most data one IDAT chunk carries (the compressed stream is cut into chunks of this size)
IDAT_BYTES = 1 << 20
#: the rows filtered at once are cut into pieces of about this many bytes (so that the filters'
#: working arrays stay small, whatever band the caller hands over)
FILTER_PIECE_BYTES = 1 << 18
#: PNG colour type by channel count: grey, RGB, RGBA
COLOUR_TYPES = {1: 0, 3: 2, 4: 6}

Staged = list[tuple[str, Path]]


class _Temporary:
    """A temporary beside ``target`` named as :mod:`barkgen.io.staging` names its own; its
    folder (and missing parents) made and listed in ``staged`` as ``("", folder)``, the
    temporary as ``(temporary, target)``. Without a caller's ``staged``, its own list, renamed
    into place by :meth:`commit`."""

    def __init__(self, target: str | os.PathLike, staged: Staged | None) -> None:
        self.target = Path(target)
        self.own = staged is None
        self.staged: Staged = [] if staged is None else staged
        folder = self.target.parent
        missing = [f for f in (folder, *folder.parents) if not f.exists()]
        try:
            folder.mkdir(parents=True, exist_ok=True)
            self.staged.extend(("", f) for f in reversed(missing))
            remove_stale_temporaries(folder)
            self.fd, self.path = tempfile.mkstemp(dir=folder, prefix=f".barkgen.{os.getpid()}.", suffix=".tmp")
        except OSError as exc:  # name the file the user asked for, not our temporary
            if self.own:  # the folders made for it (a caller's staged list has them to discard)
                discard_staged(self.staged)
            raise OSError(exc.errno, exc.strerror, str(self.target)) from None
        self.staged.append((self.path, self.target))

    def finish(self) -> None:
        """Give the synced temporary the mode a new file gets; rename it into place if it is
        ours to rename."""
        os.chmod(self.path, 0o666 & ~current_umask())
        if self.own:
            commit_staged(self.staged)

    def abort(self) -> None:
        """Remove the temporary (and, if ours, the folders made for it)."""
        if self.own:
            discard_staged(self.staged)
        else:
            try:
                os.unlink(self.path)
            except OSError:
                pass


def _check_size(width: int, height: int) -> None:
    if not (isinstance(width, int | np.integer) and isinstance(height, int | np.integer)):
        raise InvalidInputError(f"an image size is two whole numbers, not {width!r} x {height!r}")
    if not (0 < width < 2**31 and 0 < height < 2**31):
        raise InvalidInputError(f"cannot write a {width}x{height} image (each side 1 to 2**31 - 1)")


def _band_rows(rows: Any, width: int, channels: int, dtypes: tuple[type, ...], what: str) -> np.ndarray:
    """``rows`` as an ``(n, width, channels)`` array of one of ``dtypes``, or one clear error."""
    band = np.asarray(rows)
    if band.ndim == 2 and channels == 1:
        band = band[:, :, None]
    if band.ndim != 3 or band.shape[1:] != (width, channels):
        shape = f"(n, {width}) or (n, {width}, 1)" if channels == 1 else f"(n, {width}, {channels})"
        raise InvalidInputError(f"{what} takes bands of shape {shape}, not {band.shape}")
    if band.dtype not in dtypes:
        names = " or ".join(np.dtype(d).name for d in dtypes)
        raise InvalidInputError(f"{what} takes {names} rows, not {band.dtype}")
    return band


def filter_rows(rows: np.ndarray, previous: np.ndarray, bpp: int) -> np.ndarray:
    """Filter rows of a PNG image, each with the filter type that suits it (libpng's choice).

    The five filter types of the PNG specification (ISO/IEC 15948 / W3C PNG Second Edition,
    §9 Filtering) are applied to every row at once, and each row keeps the one whose output has
    the least sum of absolute values read as signed bytes (the first on a tie, None before Sub).

    Parameters
    ----------
    rows : ndarray of uint8, shape (n, stride)
        The rows' bytes, unfiltered (16-bit samples big-endian).
    previous : ndarray of uint8, shape (stride,)
        The row above the first, unfiltered (zeros above the image's first row).
    bpp : int
        Bytes per pixel (channels x bytes per sample; at least 1).

    Returns
    -------
    ndarray of uint8, shape (n, stride + 1)
        Each row's filter type followed by its filtered bytes, as they are deflated.
    """
    n, stride = rows.shape
    prior = np.empty_like(rows)
    prior[0] = previous
    prior[1:] = rows[:-1]
    out = np.empty((5, n, stride), np.uint8)  # None, Sub, Up, Average, Paeth
    out[0] = rows
    np.subtract(rows[:, bpp:], rows[:, :-bpp], out=out[1][:, bpp:])
    out[1][:, :bpp] = rows[:, :bpp]
    np.subtract(rows, prior, out=out[2])
    left, up = rows[:, :-bpp], prior[:, bpp:]
    mean = (left & up) + ((left ^ up) >> 1)  # floor((left + up) / 2) without overflow
    np.subtract(rows[:, bpp:], mean, out=out[3][:, bpp:])
    out[3][:, :bpp] = rows[:, :bpp] - (prior[:, :bpp] >> 1)
    out[4][:, :bpp] = out[2][:, :bpp]  # no left neighbours: Paeth predicts the byte above
    np.subtract(rows[:, bpp:], _paeth_predictor(left, up, prior[:, :-bpp]), out=out[4][:, bpp:])
    signed = np.minimum(out, np.negative(out))  # |byte as signed|: min(v, 256 - v)
    cost = signed.sum(axis=2, dtype=np.uint32)
    best = cost.argmin(axis=0)
    filtered = np.empty((n, stride + 1), np.uint8)
    filtered[:, 0] = best
    filtered[:, 1:] = out[best, np.arange(n)]
    return filtered


def _paeth_predictor(left: np.ndarray, up: np.ndarray, up_left: np.ndarray) -> np.ndarray:
    """The Paeth predictor of every byte (the PNG specification, §9.4): of the byte to the left,
    above and above-left, the one nearest ``left + up - up_left``, in that order on a tie."""
    a, b, c = (x.astype(np.int16) for x in (left, up, up_left))
    b -= c  # b - c: |p - a|
    a -= c  # a - c: |p - b|
    pc = np.abs(a + b)
    pa = np.abs(b)
    pb = np.abs(a)
    return np.where((pa <= pb) & (pa <= pc), left, np.where(pb <= pc, up, up_left))


class _BandStream:
    """What both streams share: the row count, the state (open, finished, aborted), and the
    rule that an error part-way aborts the stream (its temporary removed)."""

    kind = "image"

    def __init__(self, width: int, height: int) -> None:
        self.width, self.height = int(width), int(height)
        self.rows_written = 0
        self.sha256: str | None = None
        self._state = "open"

    def write(self, rows: np.ndarray) -> None:
        """Append a band of rows below those written.

        Parameters
        ----------
        rows : ndarray, shape (n, width) or (n, width, channels)
            The next ``n`` rows (``n`` may be 0), of the stream's pixel type.

        Raises
        ------
        InvalidInputError
            Another pixel type or shape, more rows than the height, or a stream no longer open
            (the stream is aborted).
        """
        self._guarded(self._write, rows)

    def close(self) -> None:
        """End the file, sync it and rename it into place (or leave it staged). Closing a
        finished stream does nothing.

        Raises
        ------
        InvalidInputError
            Fewer rows than the height were written (the stream is aborted), or the stream was
            aborted before.
        """
        if self._state != "finished":
            self._guarded(self._close)

    def _close(self) -> None:
        if self.rows_written != self.height:
            raise InvalidInputError(f"the {self.kind} has {self.rows_written} of its {self.height} rows: not written")
        self._finish()
        self._state = "finished"

    def abort(self) -> None:
        """Stop writing: remove the temporary (the target is left as it was; a stream on an
        open file leaves what it wrote there). Aborting a stream no longer open does nothing."""
        if self._state == "open":
            self._state = "aborted"
            self._release()

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, traceback) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()

    def _guarded(self, step, *args) -> None:
        """Run one step; on any error, abort the stream and let the error go on."""
        if self._state != "open":
            raise InvalidInputError(f"the {self.kind} stream is {self._state}: nothing more to write")
        try:
            step(*args)
        except BaseException:
            self.abort()
            raise

    def _count(self, band: np.ndarray) -> None:
        if self.rows_written + len(band) > self.height:
            raise InvalidInputError(
                f"{len(band)} more rows would pass the {self.kind}'s height {self.height} ({self.rows_written} written)"
            )

    def _write(self, rows: np.ndarray) -> None:
        raise NotImplementedError

    def _finish(self) -> None:
        raise NotImplementedError

    def _release(self) -> None:
        raise NotImplementedError


class PngStream(_BandStream):
    """A PNG written band by band: never the whole image, nor its encoded bytes, in memory.

    Parameters
    ----------
    target : str, PathLike or binary file
        The file. A path is written through a temporary beside it (see the module's notes on
        no-loss writes); an open binary file is written as it is, and left open.
    width, height : int
        The image's size in pixels.
    channels : {1, 3, 4}, default 3
        Grey, RGB or RGBA.
    bits : {8, 16}, default 8
        Bits per sample: rows of uint8 or uint16 (16-bit samples are stored big-endian).
    text : dict of str to str, optional
        tEXt metadata (latin-1), written before the pixels (:func:`barkgen.io.read_png_text`).
    compression : int, default 1
        zlib's level (0-9), as :func:`barkgen.io.encode_png`'s.
    staged : list of (str, Path), optional
        Rename nothing: append ``(temporary, target)`` to this list (after any folder made for
        it, as ``("", folder)``) and leave the renaming to
        :func:`barkgen.io.staging.commit_staged` (or :func:`barkgen.io.staging.discard_staged`).

    Attributes
    ----------
    rows_written : int
        The rows written so far.
    sha256 : str or None
        The SHA-256 (hex) of every byte of the file, once closed (None before).

    Raises
    ------
    InvalidInputError
        A size, channel count, bit depth or level PNG does not have; a ``staged`` list with a
        file object.

    Notes
    -----
    :meth:`write` takes bands of any number of rows, top to bottom; :meth:`close` (or the end of
    a ``with`` block) ends the file and refuses one with rows missing. An error in
    :meth:`write` or :meth:`close`, or an exception in the ``with`` block, aborts the stream:
    its temporary is removed and the target left as it was.

    Examples
    --------
    >>> import numpy as np, tempfile, os
    >>> from barkgen.io import read_image
    >>> path = os.path.join(tempfile.mkdtemp(), "ramp.png")
    >>> with PngStream(path, 5, 4, channels=1) as png:
    ...     png.write(np.zeros((3, 5), np.uint8))
    ...     png.write(np.full((1, 5), 200, np.uint8))
    >>> read_image(path)[:, 0, 0].tolist()
    [0, 0, 0, 200]
    """

    kind = "PNG"

    def __init__(
        self,
        target: str | os.PathLike | IO[bytes],
        width: int,
        height: int,
        *,
        channels: int = 3,
        bits: int = 8,
        text: dict[str, str] | None = None,
        compression: int = 1,
        staged: Staged | None = None,
    ) -> None:
        _check_size(width, height)
        if channels not in COLOUR_TYPES:
            raise InvalidInputError(f"a PNG has 1, 3 or 4 channels here, not {channels}")
        if bits not in (8, 16):
            raise InvalidInputError(f"a PNG's samples have 8 or 16 bits here, not {bits}")
        if not (isinstance(compression, int) and 0 <= compression <= 9):
            raise InvalidInputError(f"zlib's level is 0 to 9, not {compression!r}")
        header = b"".join(
            [
                PNG_SIGNATURE,
                _chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, bits, COLOUR_TYPES[channels], 0, 0, 0)),
                *(_png_text_chunk(key, value) for key, value in (text or {}).items()),
            ]
        )  # built before anything is opened: a key or value latin-1 cannot hold fails here
        super().__init__(width, height)
        self.channels, self.bits = channels, bits
        self._dtype = np.uint8 if bits == 8 else np.uint16
        self._bpp = channels * bits // 8
        self._previous = np.zeros(self.width * self._bpp, np.uint8)
        self._deflate = zlib.compressobj(compression)
        self._pending = bytearray()
        self._digest = hashlib.sha256()
        self._temporary: _Temporary | None = None
        if isinstance(target, str | os.PathLike):
            self._temporary = _Temporary(target, staged)
            self._file: IO[bytes] = os.fdopen(self._temporary.fd, "wb")
        elif staged is not None:
            raise InvalidInputError("a PNG stream stages a file by its path, not an open file")
        else:
            self._file = target
        self._guarded(self._emit, header)

    def _write(self, rows: np.ndarray) -> None:
        what = f"a {self.bits}-bit {self.channels}-channel PNG of width {self.width}"
        band = _band_rows(rows, self.width, self.channels, (self._dtype,), what)
        self._count(band)
        if self.bits == 16:
            band = band.astype(">u2", copy=False)
        data = np.ascontiguousarray(band).view(np.uint8).reshape(len(band), self.width * self._bpp)
        step = max(1, FILTER_PIECE_BYTES // data.shape[1])
        for start in range(0, len(data), step):
            piece = data[start : start + step]
            self._pending += self._deflate.compress(filter_rows(piece, self._previous, self._bpp).data)
            self._previous = piece[-1].copy()
            self._emit_idat(final=False)
        self.rows_written += len(band)

    def _finish(self) -> None:
        """The last IDAT chunk and IEND; the temporary synced and renamed into place."""
        self._pending += self._deflate.flush()
        self._emit_idat(final=True)
        self._emit(_chunk(b"IEND", b""))
        self._file.flush()
        if self._temporary is not None:
            os.fsync(self._file.fileno())
            self._file.close()
            self._temporary.finish()
        self.sha256 = self._digest.hexdigest()

    def _release(self) -> None:
        if self._temporary is not None:
            try:
                self._file.close()
            finally:
                self._temporary.abort()

    def _emit(self, data: bytes) -> None:
        self._file.write(data)
        self._digest.update(data)

    def _emit_idat(self, final: bool) -> None:
        """Write the pending compressed bytes as IDAT chunks of :data:`IDAT_BYTES` (and, if
        ``final``, the rest)."""
        whole = len(self._pending) if final else len(self._pending) // IDAT_BYTES * IDAT_BYTES
        view = memoryview(self._pending)
        for start in range(0, whole, IDAT_BYTES):
            self._emit(_chunk(b"IDAT", view[start : min(start + IDAT_BYTES, whole)]))
        view.release()
        del self._pending[:whole]


def _chunk(kind: bytes, data: bytes | memoryview) -> bytes:
    """A PNG chunk: length, type, data, CRC of type and data."""
    return struct.pack(">I", len(data)) + kind + bytes(data) + struct.pack(">I", zlib.crc32(data, zlib.crc32(kind)))


class ExrStream(_BandStream):
    """A one-channel float32 OpenEXR map written band by band, as :func:`encode_exr
    <barkgen.io.material.encode_exr>` writes it whole (channel ``Y``, ZIP compression, scanlines;
    the ``[exr]`` extra, PyPI ``openexr``), through OpenEXR's ``OutputFile.writePixels`` (kept by
    OpenEXR 3.x's Python bindings for older code; the newer ``OpenEXR.File`` writes only whole
    images).

    Parameters
    ----------
    target : str or PathLike
        The file, written through a temporary beside it (see the module's notes on no-loss
        writes; OpenEXR opens the file by its name, so an open file cannot be given).
    width, height : int
        The map's size in pixels.
    staged : list of (str, Path), optional
        As :class:`PngStream`'s: append ``(temporary, target)`` and rename nothing.

    Attributes
    ----------
    rows_written : int
        The rows written so far.
    sha256 : str or None
        The SHA-256 (hex) of the file once closed, read back from the synced temporary once
        (OpenEXR writes the file itself); None before.

    Raises
    ------
    InvalidInputError
        A size OpenEXR cannot write.
    MissingExtraError
        OpenEXR is not installed.

    Notes
    -----
    :meth:`write` takes ``(n, width)`` (or ``(n, width, 1)``) bands of float16, float32 or
    float64 values, stored as float32; OpenEXR compresses every 16 scanlines (ZIP's block) as
    they are complete, so a band may have any number of rows.
    """

    kind = "EXR"

    def __init__(self, target: str | os.PathLike, width: int, height: int, *, staged: Staged | None = None) -> None:
        from barkgen._shared.extras import require_extra

        _check_size(width, height)
        require_extra("exr", "32-bit EXR maps")
        import Imath
        import OpenEXR

        header = OpenEXR.Header(int(width), int(height))
        header["channels"] = {"Y": Imath.Channel(Imath.PixelType(Imath.PixelType.FLOAT))}
        header["compression"] = Imath.Compression(Imath.Compression.ZIP_COMPRESSION)
        super().__init__(width, height)
        self._temporary = _Temporary(target, staged)
        os.close(self._temporary.fd)
        try:
            self._exr = OpenEXR.OutputFile(self._temporary.path, header)
        except BaseException:
            self._temporary.abort()
            raise

    def _write(self, rows: np.ndarray) -> None:
        what = f"a one-channel EXR of width {self.width}"
        band = _band_rows(rows, self.width, 1, (np.float16, np.float32, np.float64), what)
        self._count(band)
        if len(band):
            self._exr.writePixels({"Y": np.ascontiguousarray(band[:, :, 0], np.float32)}, len(band))
        self.rows_written += len(band)

    def _finish(self) -> None:
        """OpenEXR's file closed; the temporary synced, hashed and renamed into place."""
        self._exr.close()
        digest = hashlib.sha256()
        with open(self._temporary.path, "rb") as fh:
            for block in iter(lambda: fh.read(1 << 20), b""):
                digest.update(block)
            os.fsync(fh.fileno())
        self._temporary.finish()
        self.sha256 = digest.hexdigest()

    def _release(self) -> None:
        try:
            self._exr.close()
        except Exception:  # an unfinished file: it is removed anyway
            pass
        finally:
            self._temporary.abort()
