"""The image formats :mod:`barkgen.io.images` reads besides PNG, JPEG, TIFF, WebP, GIF and BMP:
PPM/PGM (binary ``P6``/``P5``, 8 and 16 bits), TGA (uncompressed and RLE), OpenEXR and
Radiance HDR; and the reading of a pipe (``-``, ``/dev/stdin``) up to a byte limit.

Each is known by its content and its declared size is read from its header (:func:`header_size`)
before a pixel is decoded. TGA has no magic number: a header is taken as TGA's when its fields
agree with each other (the image type, the colour map, the bits per pixel) and, uncompressed,
with the data's length.

Floating-point pictures (EXR, HDR) hold scene-linear light. As a photo they are tone-mapped
(:func:`tone_map`): scaled so that the 99.5th percentile of each pixel's brightest channel is
white, clipped to 0-1 and encoded with the sRGB curve (IEC 61966-2-1), as 16 bits. As a map of
values (a height, an ``--extra``; ``linear=True``) they are kept linear (:func:`linear_unit`).
"""

from __future__ import annotations

import os
import re
import stat
import struct
import warnings
from pathlib import Path

import numpy as np

from barkgen.errors import ImageReadError, ImageTooLargeError

EXR_MAGIC = b"\x76\x2f\x31\x01"
HDR_MAGICS = (b"#?RADIANCE", b"#?RGBE")
#: the percentile of the brightest channel the tone map takes as white
TONE_MAP_PERCENTILE = 99.5
#: the formats read, as the error for another file names them
FORMAT_NAMES = "PNG, JPEG, TIFF, WebP, GIF, BMP, PPM/PGM, TGA, OpenEXR or Radiance HDR"

_PNM_HEADER = re.compile(rb"\AP([56])(?:\s+|#[^\n]*\n)+(\d+)(?:\s+|#[^\n]*\n)+(\d+)(?:\s+|#[^\n]*\n)+(\d+)\s")
_HDR_RESOLUTION = re.compile(rb"\n([-+])([XY]) +(\d+) +([-+])([XY]) +(\d+)\r?\n")
_TGA_TYPES = {1, 2, 3, 9, 10, 11}


class ImageContentWarning(UserWarning):
    """An input image was read with a loss its user should know of: an animation's later frames,
    floating-point values outside 0-1 (a ``UserWarning``)."""


# ------------------------------------------------------------------------ sniffing and sizes


def _pnm(data: bytes) -> tuple[int, int, int, int] | None:
    """``(kind, width, height, maxval)`` of a binary PGM (5) / PPM (6) header, else None."""
    m = _PNM_HEADER.match(data[:1024])
    if m is None:
        return None
    kind, width, height, maxval = (int(g) for g in m.groups())
    return (kind, width, height, maxval) if 0 < maxval < 65536 else None


def _tga(data: bytes, size: int) -> tuple[int, int] | None:
    """``(width, height)`` when the first 18 bytes are a consistent TGA header, else None."""
    if len(data) < 18:
        return None
    id_len, cmap_type, kind, _, cmap_len, cmap_bits, _, _, width, height, bits, desc = struct.unpack(
        "<BBBHHBHHHHBB", data[:18]
    )
    if kind not in _TGA_TYPES or bits not in (8, 15, 16, 24, 32) or width == 0 or height == 0 or desc & 0xC0:
        return None
    palette = kind in (1, 9)
    if cmap_type != int(palette) or (palette and (cmap_bits not in (15, 16, 24, 32) or bits != 8)):
        return None
    if not palette and (cmap_len or cmap_bits):
        return None
    if kind in (3, 11) and bits != 8 and bits != 16:  # (grey: 8 bits, or 16 with alpha)
        return None
    if kind <= 3:  # uncompressed: the pixels the header declares are there
        need = 18 + id_len + cmap_len * ((cmap_bits + 7) // 8) + width * height * ((bits + 7) // 8)
        if size < need:
            return None
    return width, height


def _exr_size(data: bytes) -> tuple[int, int] | None:
    """``(width, height)`` of an OpenEXR header's ``dataWindow`` (its first part's)."""
    pos = 8
    while pos < len(data) and data[pos] != 0:
        name_end = data.find(b"\x00", pos)
        type_end = data.find(b"\x00", name_end + 1)
        if name_end < 0 or type_end < 0 or type_end + 5 > len(data):
            return None
        (length,) = struct.unpack("<i", data[type_end + 1 : type_end + 5])
        value = data[type_end + 5 : type_end + 5 + length]
        if data[pos:name_end] == b"dataWindow" and data[name_end + 1 : type_end] == b"box2i" and len(value) == 16:
            xmin, ymin, xmax, ymax = struct.unpack("<iiii", value)
            return max(0, xmax - xmin + 1), max(0, ymax - ymin + 1)
        if length < 0:
            return None
        pos = type_end + 5 + length
    return None


def _hdr_size(data: bytes) -> tuple[int, int] | None:
    """``(width, height)`` of a Radiance HDR's resolution line (after its blank line)."""
    end = data.find(b"\n\n")
    m = _HDR_RESOLUTION.match(data, end + 1) if end >= 0 else None
    if m is None:
        return None
    first, second = int(m.group(3)), int(m.group(6))
    return (second, first) if m.group(2) == b"Y" else (first, second)


def sniff_format(head: bytes, size: int) -> str | None:
    """The name of the format (``"pnm"``, ``"tga"``, ``"exr"``, ``"hdr"``) the first bytes
    say, of a file of ``size`` bytes; None for another content."""
    if head.startswith(EXR_MAGIC):
        return "exr"
    if head.startswith(HDR_MAGICS):
        return "hdr"
    if head[:2] in (b"P5", b"P6") and head[2:3].isspace():
        return "pnm"
    return "tga" if _tga(head, size) is not None else None


def header_size(data: bytes, size: int, name) -> tuple[int, int]:
    """``(width, height)`` a PPM/PGM, TGA, EXR or HDR header declares (``data``: its first bytes,
    of a file of ``size`` bytes), without decoding a pixel."""
    kind = sniff_format(data, size)
    found = {"pnm": lambda: (_pnm(data) or (0, 0, 0, 0))[1:3], "tga": lambda: _tga(data, size)}.get(
        kind or "", lambda: _exr_size(data) if kind == "exr" else _hdr_size(data)
    )()
    if not found or not all(found):
        raise ImageReadError(f"{name}: truncated or corrupt {(kind or 'image').upper()} header")
    return int(found[0]), int(found[1])


# ------------------------------------------------------------------------ decoding


def decode_pnm(data: bytes, name) -> np.ndarray:
    """A binary PGM/PPM's pixels, ``(H, W, C)`` uint8 (maxval <= 255) or uint16 (big-endian
    samples), scaled to the full range when maxval is not 255 or 65535."""
    header = _pnm(data)
    if header is None:
        raise ImageReadError(f"{name}: truncated or corrupt PPM/PGM header")
    kind, width, height, maxval = header
    m = _PNM_HEADER.match(data[:1024])
    assert m is not None
    channels = 3 if kind == 6 else 1
    dtype = np.dtype(">u2") if maxval > 255 else np.dtype(np.uint8)
    count = width * height * channels
    pixels = np.frombuffer(data, dtype, count=min(count, (len(data) - m.end()) // dtype.itemsize), offset=m.end())
    if pixels.size < count:
        raise ImageReadError(f"{name}: truncated PPM/PGM ({pixels.size} of {count} samples)")
    arr = pixels.reshape(height, width, channels)
    full = 65535 if maxval > 255 else 255
    if maxval == full:
        return arr.astype(np.uint16 if full == 65535 else np.uint8)
    scaled = np.round(np.minimum(arr, maxval).astype(np.float64) * (full / maxval))
    return scaled.astype(np.uint16 if full == 65535 else np.uint8)


def decode_exr(data: bytes, name) -> np.ndarray:
    """An OpenEXR's pixels as float32 ``(H, W, C)``: its R, G, B (A) channels, else its one
    channel (``Y``, ``Z``, a height); the ``[exr]`` extra (PyPI ``openexr``)."""
    import tempfile

    from barkgen._shared.extras import require_extra

    require_extra("exr", "reading OpenEXR images")
    import OpenEXR

    with tempfile.TemporaryDirectory(prefix="barkgen-exr-") as folder:
        path = os.path.join(folder, "in.exr")
        with open(path, "wb") as f:
            f.write(data)
        try:
            with OpenEXR.File(path, separate_channels=True) as exr:
                channels = {k: np.asarray(v.pixels) for k, v in exr.channels().items()}
        except Exception as exc:  # the binding raises RuntimeError and others for a bad file
            raise ImageReadError(f"{name}: not a readable OpenEXR image ({exc})") from None
    plain = {k.rsplit(".", 1)[-1]: v for k, v in channels.items()}
    names = [c for c in ("R", "G", "B", "A") if c in plain]
    if len(names) < 3:
        names = ["Y"] if "Y" in plain else sorted(plain)[:1]
    if not names:
        raise ImageReadError(f"{name}: an OpenEXR image with no channel")
    return np.dstack([plain[c].astype(np.float32) for c in names])


def decode_hdr(data: bytes, name) -> np.ndarray:
    """A Radiance HDR's pixels as float32 RGB ``(H, W, 3)`` (OpenCV's RGBE decoder)."""
    import cv2

    arr = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    if arr is None or arr.dtype != np.float32:
        raise ImageReadError(f"{name}: truncated or corrupt Radiance HDR image")
    return arr[:, :, ::-1] if arr.ndim == 3 else arr


def decode_tga(data: bytes, name):
    """A TGA's pixels (Pillow's TGA decoder) and whether it has alpha."""
    import io

    from PIL import Image

    try:
        with Image.open(io.BytesIO(data), formats=["TGA"]) as im:
            im.load()
            has_alpha = im.mode in ("RGBA", "LA")
            if im.mode in ("L", "1", "LA"):
                return np.asarray(im.convert("L")), has_alpha
            return np.asarray(im.convert("RGB")), has_alpha
    except Exception as exc:  # Pillow raises OSError, SyntaxError, ValueError for a bad file
        raise ImageReadError(f"{name}: truncated or corrupt TGA image ({exc})") from None


def tone_map(linear: np.ndarray) -> np.ndarray:
    """A scene-linear float picture as a 16-bit photo: divided by the
    :data:`TONE_MAP_PERCENTILE` th percentile of each pixel's brightest channel (that level is
    white; brighter is clipped), negative and non-finite values 0, then the sRGB transfer curve
    (IEC 61966-2-1: ``12.92 v`` below 0.0031308, else ``1.055 v^(1/2.4) - 0.055``), rounded to
    0-65535."""
    values = np.nan_to_num(linear.astype(np.float64), copy=False, nan=0.0, posinf=0.0, neginf=0.0)
    np.maximum(values, 0.0, out=values)
    brightest = np.max(values, axis=2) if values.size else values
    white = float(np.percentile(brightest, TONE_MAP_PERCENTILE)) if values.size else 0.0
    if white <= 0:
        white = float(values.max()) if values.size and values.max() > 0 else 1.0
    values /= white
    np.minimum(values, 1.0, out=values)
    dark = values <= 0.0031308
    encoded = np.power(values, 1 / 2.4)
    encoded *= 1.055
    encoded -= 0.055
    encoded[dark] = values[dark] * 12.92
    encoded *= 65535.0
    return np.round(encoded, out=encoded).astype(np.uint16)


def linear_unit(values: np.ndarray, name) -> np.ndarray:
    """A float map kept linear as 16 bits: values in 0-1 as they are (``round(v * 65535)``);
    a map outside 0-1 (a height in centimetres) scaled linearly from its own lowest and highest
    finite value to 0-1, said in an :class:`ImageContentWarning`; non-finite values 0."""
    finite = np.isfinite(values)
    low, high = (float(values[finite].min()), float(values[finite].max())) if finite.any() else (0.0, 1.0)
    v = np.where(finite, values, low).astype(np.float64)
    if low < 0 or high > 1:
        warnings.warn(
            f"{name}: values from {low:.4g} to {high:.4g} were scaled linearly to 0-1",
            ImageContentWarning,
            stacklevel=4,
        )
        v = (v - low) / (high - low) if high > low else np.zeros_like(v)
    return np.round(np.clip(v, 0.0, 1.0) * 65535.0).astype(np.uint16)


# ------------------------------------------------------------------------ pipes


#: the bytes read from each pipe or device (``(device, inode)``), kept until the image is read:
#: a command checks the image's size from its header, then reads it (a pipe is read once)
_STREAMS: dict[tuple[int, int], bytes] = {}


def is_stream(path: Path) -> bool:
    """``path`` is ``-`` (the standard input), a pipe or a character device (``/dev/stdin``)."""
    if str(path) == "-":
        return True
    try:
        mode = path.stat().st_mode
    except OSError:
        return False
    return stat.S_ISFIFO(mode) or stat.S_ISCHR(mode) or stat.S_ISSOCK(mode)


def read_stream(path: Path, limit: int, sniff: int, is_image, keep: bool = False) -> bytes:
    """The bytes of a pipe or device, read once up to ``limit`` bytes: its first ``sniff``
    bytes must pass ``is_image``, else one line and nothing more read; more than ``limit``
    bytes is refused once the limit is passed (the rest is never read). ``keep`` keeps them for
    the next read of the same pipe (a size check before the read)."""
    stdin = str(path) == "-"
    try:
        info = os.fstat(0) if stdin else path.stat()
        key = (info.st_dev, info.st_ino)
        data = _STREAMS.get(key)
        if data is None:
            fd = 0 if stdin else os.open(path, os.O_RDONLY)
            try:
                data = _read_bounded(fd, limit, sniff, is_image)
            finally:
                if not stdin:
                    os.close(fd)
            _STREAMS[key] = data
    except OSError as exc:
        raise ImageReadError(f"{path}: cannot read ({exc.strerror or exc})") from None
    if not keep:
        _STREAMS.pop(key, None)
    if not data:
        raise ImageReadError(f"{path}: nothing to read (0 bytes)")
    if not is_image(data[:sniff], len(data)):
        raise ImageReadError(f"{path}: not a regular file and not an image ({FORMAT_NAMES} by its content)")
    if len(data) > limit:
        raise ImageTooLargeError(
            f"{path}: more than the {_amount(limit)} an image may be (read from a pipe; stopped there)"
        )
    return data


def _amount(count: int) -> str:
    """A count of bytes in the unit that reads best (``1 GiB``, ``64 KiB``)."""
    unit = next(u for u in (3, 2, 1, 0) if count >= 1024**u)
    return f"{count / 1024**unit:g} {('bytes', 'KiB', 'MiB', 'GiB')[unit]}"


def _read_bounded(fd: int, limit: int, sniff: int, is_image) -> bytes:
    """Up to ``limit + 1`` bytes of ``fd``; only the first ``sniff`` when they are no image."""
    head = b""
    while len(head) < sniff:
        chunk = os.read(fd, sniff - len(head))
        if not chunk:
            return head
        head += chunk
    if not is_image(head, limit):
        return head  # not an image: nothing more read (a device of zeros)
    chunks, total = [head], len(head)
    while total <= limit:
        chunk = os.read(fd, min(1 << 20, limit + 1 - total))
        if not chunk:
            break
        chunks.append(chunk)
        total += len(chunk)
    return b"".join(chunks)
