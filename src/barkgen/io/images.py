"""Reading and writing images: PNG/JPEG/TIFF/WebP/GIF/BMP, PPM/PGM, TGA, OpenEXR and Radiance
HDR in (:mod:`barkgen.io.image_formats`), from a file or a pipe; 8- or 16-bit PNG out, atomically.

Images are numpy arrays of shape ``(H, W, C)`` with ``C`` = 1 (grey) or 3 (RGB) and dtype
``uint8`` or ``uint16``: a floating-point picture (EXR, HDR) is tone-mapped as a photo and kept
linear as a map (``linear=True``). Alpha channels are dropped with a warning. Every write goes to a
temporary file in the destination folder that is renamed into place, so an interrupted or failed
write never leaves a half-written file under the requested name.
"""

from __future__ import annotations

import io
import os
import struct
import warnings
import zlib
from collections.abc import Callable
from pathlib import Path

import numpy as np

import barkgen.io.image_formats as formats
from barkgen.errors import ImageReadError, ImageTooLargeError, InvalidInputError
from barkgen.io.image_formats import FORMAT_NAMES, ImageContentWarning
from barkgen.io.staging import write_bytes_atomic

_TIFF_MAGIC = (b"II*\x00", b"MM\x00*")
_PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


class AlphaDroppedWarning(UserWarning):
    """An input image had an alpha channel, which barkgen ignores (a ``UserWarning``)."""


#: the EXIF tag of the camera's orientation (1 = as stored)
_EXIF_ORIENTATION = 0x0112


#: the largest image file barkgen reads, in bytes (a 144-megapixel 16-bit TIFF, uncompressed,
#: is 0.9 GiB)
MAX_IMAGE_BYTES = 1 << 30
#: the first bytes of the formats barkgen reads (WebP: ``RIFF....WEBP``, checked apart)
_IMAGE_MAGICS = (_PNG_MAGIC, b"\xff\xd8\xff", *_TIFF_MAGIC, b"GIF87a", b"GIF89a", b"BM")
#: how much of a file is read to tell whether it is an image at all
_SNIFF_BYTES = 32
#: how much of a file :func:`image_size` reads first for the image's size
_HEADER_BYTES = 1 << 16


def _known_start(head: bytes) -> bool:
    return head.startswith(_IMAGE_MAGICS) or (head[:4] == b"RIFF" and head[8:12] == b"WEBP")


def _other_format(data: bytes, size: int | None = None) -> str | None:
    """``pnm``, ``tga``, ``exr`` or ``hdr`` (:mod:`~barkgen.io.image_formats`) for a file of
    ``size`` bytes (default: ``data``'s) that is none of Pillow's and tifffile's formats."""
    return None if _known_start(data) else formats.sniff_format(data, len(data) if size is None else size)


def _is_image_start(head: bytes, size: int) -> bool:
    return _known_start(head) or _other_format(head, size) is not None


def _open_checked(path: Path):
    """``path`` opened for reading once it is known to be a regular, non-empty file of at most
    :data:`MAX_IMAGE_BYTES` that starts as an image does (by its content, whatever its name):
    a 2 GB file of zeros named ``.png`` is refused before more than its first bytes are read (a
    pipe or a device is read by :func:`~barkgen.io.image_formats.read_stream`, bounded alike).
    Returns ``(file, size)``."""
    import stat

    try:
        info = path.stat()
    except FileNotFoundError:
        raise ImageReadError(f"{path}: no such file") from None
    except OSError as exc:
        raise ImageReadError(f"{path}: cannot read ({exc.strerror or exc})") from None
    if stat.S_ISDIR(info.st_mode):
        raise ImageReadError(f"{path}: is a directory, not an image")
    if not stat.S_ISREG(info.st_mode):
        raise ImageReadError(f"{path}: not a regular file (a block device)")
    if info.st_size == 0:
        raise ImageReadError(f"{path}: file is empty (0 bytes)")
    if info.st_size > MAX_IMAGE_BYTES:
        raise ImageTooLargeError(
            f"{path}: {info.st_size / 2**30:.3g} GiB is more than the "
            f"{MAX_IMAGE_BYTES / 2**30:g} GiB an image file may be"
        )
    try:
        fh = open(path, "rb")
    except OSError as exc:
        raise ImageReadError(f"{path}: cannot read ({exc.strerror or exc})") from None
    if not _is_image_start(fh.read(_SNIFF_BYTES), info.st_size):
        fh.close()
        raise ImageReadError(f"{path}: not an image ({FORMAT_NAMES} by its content)")
    fh.seek(0)
    return fh, info.st_size


def _check_file(path: Path, keep: bool = False) -> bytes:
    if formats.is_stream(path):  # a pipe (``-``, /dev/stdin): read once, up to the same limit
        return formats.read_stream(path, MAX_IMAGE_BYTES, _SNIFF_BYTES, _is_image_start, keep=keep)
    fh, size = _open_checked(path)
    with fh:
        try:
            data = fh.read(size + 1)
        except OSError as exc:
            raise ImageReadError(f"{path}: cannot read ({exc.strerror or exc})") from None
    if len(data) > MAX_IMAGE_BYTES:  # (it grew while read)
        raise ImageTooLargeError(f"{path}: more than the {MAX_IMAGE_BYTES / 2**30:g} GiB an image file may be")
    return data


def read_image_bytes(path: str | os.PathLike) -> bytes:
    """The bytes of an image file, not decoded; :func:`decode_image` decodes them.

    Parameters
    ----------
    path : str or PathLike
        The file.

    Returns
    -------
    bytes

    Raises
    ------
    ImageReadError
        A missing, empty or unreadable file (:func:`read_image`'s one-line errors).
    """
    return _check_file(Path(path))


def _normalise(arr: np.ndarray, path, has_alpha: bool) -> np.ndarray:
    """Bring a decoded array to (H, W, 1|3) uint8/uint16, dropping alpha."""
    if arr.dtype.kind == "f":
        finite = np.isfinite(arr)
        if not finite.all() or (arr[finite].size and (arr[finite].min() < 0 or arr[finite].max() > 1)):
            warnings.warn(
                f"{path}: floating-point pixels outside 0-1 (or not finite) were clipped to 0-1",
                ImageContentWarning,
                stacklevel=3,
            )
        arr = np.round(np.clip(np.nan_to_num(arr), 0.0, 1.0) * 65535.0).astype(np.uint16)
    elif arr.dtype == np.bool_:
        arr = arr.astype(np.uint8) * 255
    elif arr.dtype in (np.uint32, np.int32):  # a 32-bit integer TIFF: its range onto 16 bits
        top = 2**32 - 1 if arr.dtype == np.uint32 else 2**31 - 1
        arr = np.round(np.clip(arr.astype(np.float64), 0, top) * (65535 / top)).astype(np.uint16)
    elif arr.dtype not in (np.uint8, np.uint16):
        raise ImageReadError(f"{path}: unsupported pixel type {arr.dtype} (use 8- or 16-bit)")
    if arr.ndim == 2:
        arr = arr[:, :, None]
    if arr.ndim != 3 or arr.shape[2] not in (1, 2, 3, 4):
        raise ImageReadError(f"{path}: unsupported image layout {arr.shape}")
    if arr.shape[2] in (2, 4):
        has_alpha = True
        arr = arr[:, :, :-1]
    if has_alpha:
        warnings.warn(f"{path}: alpha channel dropped", AlphaDroppedWarning, stacklevel=3)
    if arr.shape[0] == 0 or arr.shape[1] == 0:
        raise ImageReadError(f"{path}: image has no pixels")
    return np.ascontiguousarray(arr)


def _png_bit_depth(data: bytes) -> int:
    # IHDR is always the first chunk: 8 magic + 4 length + 4 type + 4 w + 4 h + 1 depth.
    return data[24] if len(data) > 25 and data.startswith(_PNG_MAGIC) else 8


def read_image(path: str | os.PathLike, *, linear: bool = False) -> np.ndarray:
    """Read an image file into an ``(H, W, C)`` uint8/uint16 array (C = 1 or 3).

    Supports PNG, JPEG, TIFF (8, 16 and 32 bits), WebP, GIF, BMP, PPM/PGM, TGA, OpenEXR and
    Radiance HDR, grey, RGB and RGBA (alpha is dropped with an :class:`AlphaDroppedWarning`);
    ``-``, a pipe or ``/dev/stdin`` is read up to :data:`MAX_IMAGE_BYTES`.

    Parameters
    ----------
    path : str or PathLike
        The file; its content decides the format, not its name.
    linear : bool, default False
        How an EXR or HDR's floating-point values are read (:func:`decode_image`): False for a
        photo (tone-mapped), True for a map of values (a height, an ``--extra``: kept linear).

    Returns
    -------
    ndarray of uint8 or uint16, shape (H, W, C)

    Raises
    ------
    ImageReadError
        A missing, empty, truncated or unreadable file (one line).

    Examples
    --------
    >>> import barkgen
    >>> photo = read_image(barkgen.sample_exemplar_path())
    >>> photo.shape, photo.dtype.name
    ((1024, 1024, 3), 'uint8')
    """
    path = Path(path)
    return decode_image(_check_file(path), path, linear=linear)


def _image_size(data: bytes, name, size: int | None = None) -> tuple[int, int]:
    """``(width, height)`` from the image's header (``data``: at least its first bytes, of a
    file of ``size`` bytes), without decoding its pixels."""
    if _other_format(data, size) is not None:
        return formats.header_size(data, len(data) if size is None else size, name)
    if data[:4] in _TIFF_MAGIC:
        import tifffile

        try:
            with tifffile.TiffFile(io.BytesIO(data)) as tif:
                shape = tif.pages[0].shape
        except Exception as exc:  # tifffile raises many types for corrupt files
            raise ImageReadError(f"{name}: not a readable TIFF image ({exc})") from None
        if len(shape) == 3 and shape[0] in (1, 3, 4) and shape[2] not in (1, 2, 3, 4):
            return int(shape[2]), int(shape[1])
        return int(shape[1]), int(shape[0])
    from PIL import Image, UnidentifiedImageError

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            with Image.open(io.BytesIO(data)) as im:
                width, height = im.size
                # as read: a photo its EXIF says to turn a quarter is read turned. A PNG's EXIF
                # counts when it comes before the pixels: Pillow decodes the whole image to look
                # for one after them (a 64 MP PNG of 69 KB cost 62 MB and half a second)
                header_exif = im.format != "PNG" or "exif" in im.info
                turned = header_exif and im.getexif().get(_EXIF_ORIENTATION) in (5, 6, 7, 8)
                return (height, width) if turned else (width, height)
    except Image.DecompressionBombError as exc:  # over twice Pillow's own limit
        if data.startswith(_PNG_MAGIC) and len(data) >= 24:  # (barkgen's own 16K maps: its header)
            return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")
        raise ImageTooLargeError(f"{name}: image too large ({exc})") from None
    except UnidentifiedImageError:
        raise ImageReadError(f"{name}: not an image (unrecognised format)") from None
    except (OSError, SyntaxError, ValueError) as exc:
        raise ImageReadError(f"{name}: truncated or corrupt image ({exc})") from None


def image_size(path: str | os.PathLike) -> tuple[int, int]:
    """``(width, height)`` of an image file from its header, without decoding its pixels (a
    small file may declare a huge image), turned as :func:`read_image` turns it (EXIF
    orientation).

    Raises
    ------
    ImageReadError
        A missing, empty or unreadable file, or not an image.
    """
    path = Path(path)
    if formats.is_stream(path):  # read once (kept for the read that follows), up to the limit
        return _image_size(_check_file(path, keep=True), path)
    fh, size = _open_checked(path)
    with fh:  # the header is enough: a 117 KB file may declare a huge image
        head = fh.read(min(size, _HEADER_BYTES))
    try:
        return _image_size(head, path, size)
    except ImageReadError:
        if size <= _HEADER_BYTES:
            raise
    return _image_size(_check_file(path), path)  # a header past the first bytes (EXIF, TIFF IFD)


def decode_image(
    data: bytes, name: str | os.PathLike = "image", *, max_pixels: int | None = None, linear: bool = False
) -> np.ndarray:
    """Decode the bytes of an image file (what :func:`read_image` reads).

    The content decides the format, never a file name.

    Parameters
    ----------
    data : bytes
        The file's bytes (any format :func:`read_image` reads).
    name : str or PathLike, default "image"
        What error messages call it.
    max_pixels : int, optional
        Refuse larger images with :class:`ImageTooLargeError`, read from the header before any
        pixel is decoded.
    linear : bool, default False
        An EXR or HDR (scene-linear light) is tone-mapped when False, as a photo is
        (:func:`barkgen.io.image_formats.tone_map`: the 99.5th percentile of the brightest
        channel is white, then the sRGB curve, 16 bits); kept linear when True, as a height or
        an extra map is (:func:`barkgen.io.image_formats.linear_unit`: 0-1 as 0-65535, a map
        outside 0-1 scaled from its own range with a warning). A 32-bit float TIFF is read
        as its values 0-1 either way (clipped outside, with a warning).

    Returns
    -------
    ndarray of uint8 or uint16, shape (H, W, C), C = 1 or 3

    Raises
    ------
    ImageReadError
        Empty, truncated or undecodable data.
    ImageTooLargeError
        More than ``max_pixels`` pixels.
    """
    path = name
    if not data:
        raise ImageReadError(f"{name}: file is empty (0 bytes)")
    if max_pixels is not None:
        width, height = _image_size(data, name)
        if width * height > max_pixels:
            raise ImageTooLargeError(
                f"{name}: {width}x{height} px is {width * height / 1e6:.1f} "
                f"megapixels, more than the limit of {max_pixels / 1e6:g}"
            )
    other = _other_format(data)
    if other is not None:
        return _decode_other(other, data, path, linear)
    arr: np.ndarray | None
    if data[:4] in _TIFF_MAGIC:
        import tifffile

        try:
            arr = tifffile.imread(io.BytesIO(data))
        except Exception as exc:  # tifffile raises many types for corrupt files
            raise ImageReadError(f"{path}: not a readable TIFF image ({exc})") from None
        if arr.ndim == 3 and arr.shape[0] in (1, 3, 4) and arr.shape[2] not in (1, 2, 3, 4):
            arr = np.moveaxis(arr, 0, -1)  # planar TIFF
        return _normalise(arr, path, has_alpha=False)

    from PIL import Image, ImageOps, UnidentifiedImageError

    try:
        with Image.open(io.BytesIO(data)) as opened:
            opened.load()  # decodes fully: raises on truncated data
            frames = getattr(opened, "n_frames", 1)
            if frames > 1:
                warnings.warn(
                    f"{path}: an animation of {frames} frames; its first frame is used",
                    ImageContentWarning,
                    stacklevel=2,
                )
            # a phone photo stands as its camera's orientation tag says, not as its sensor read it
            im = ImageOps.exif_transpose(opened) if opened.getexif().get(_EXIF_ORIENTATION, 1) != 1 else opened
            mode = im.mode
            has_alpha = mode in ("RGBA", "LA", "PA") or (mode == "P" and "transparency" in im.info)
            if _png_bit_depth(data) == 16 and mode not in ("I;16", "I;16B", "I"):
                arr = None  # 16-bit colour PNG: Pillow keeps 8 bits, decode with OpenCV
            elif mode in ("I;16", "I;16B", "I;16L"):
                arr = np.asarray(im, dtype=np.uint16)
            elif mode == "I":
                arr = np.clip(np.asarray(im), 0, 65535).astype(np.uint16)
            elif mode == "F":
                arr = np.asarray(im, dtype=np.float32)
            elif mode in ("L", "1"):
                arr = np.asarray(im.convert("L"))
            elif mode == "LA":
                arr = np.asarray(im)[:, :, 0]
            elif mode == "RGBA":
                arr = np.asarray(im)[:, :, :3]
            else:
                arr = np.asarray(im.convert("RGB"))
    except UnidentifiedImageError:
        raise ImageReadError(f"{path}: not an image (unrecognised format)") from None
    except Image.DecompressionBombError as exc:
        # Pillow's own limit is for images from anywhere (179 megapixels): a PNG past it, such as
        # barkgen's own 16384² maps, is decoded by OpenCV (whose limit is 1 gigapixel), the caller
        # having checked its size against its own ``max_pixels`` already
        if not data.startswith(_PNG_MAGIC):
            raise ImageTooLargeError(f"{path}: image too large ({exc})") from None
        arr, has_alpha = None, False
    except (OSError, SyntaxError, ValueError) as exc:
        raise ImageReadError(f"{path}: truncated or corrupt image ({exc})") from None

    if arr is None:
        import cv2

        dec = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
        if dec is None:
            raise ImageReadError(f"{path}: truncated or corrupt PNG")
        if dec.ndim == 3:
            has_alpha = has_alpha or dec.shape[2] == 4
            dec = dec[:, :, [2, 1, 0, 3][: dec.shape[2]]] if dec.shape[2] == 4 else dec[:, :, ::-1]
        arr = dec
    return _normalise(np.asarray(arr), path, has_alpha)


def _decode_other(kind: str, data: bytes, path, linear: bool) -> np.ndarray:
    """A PPM/PGM, TGA, EXR or HDR decoded (:mod:`~barkgen.io.image_formats`)."""
    if kind == "pnm":
        return _normalise(formats.decode_pnm(data, path), path, has_alpha=False)
    if kind == "tga":
        pixels, tga_alpha = formats.decode_tga(data, path)
        return _normalise(pixels, path, tga_alpha)
    values = formats.decode_exr(data, path) if kind == "exr" else formats.decode_hdr(data, path)
    has_alpha = values.shape[2] in (2, 4)
    if has_alpha:
        values = values[:, :, :-1]
    pixels = formats.linear_unit(values, path) if linear else formats.tone_map(values)
    return _normalise(pixels, path, has_alpha)


def to_bits(image: np.ndarray, bits: int) -> np.ndarray:
    """Convert a uint8/uint16 image to ``bits`` (8 or 16) per channel, rounding.

    Parameters
    ----------
    image : ndarray of uint8 or uint16
        The image.
    bits : {8, 16}
        The depth wanted.

    Returns
    -------
    ndarray
        ``image`` itself when it has that depth already, else a converted copy
        (8 -> 16 multiplies by 257).

    Raises
    ------
    InvalidInputError
        Another depth or pixel type.

    Examples
    --------
    >>> import numpy as np
    >>> to_bits(np.array([[255]], np.uint8), 16).tolist()
    [[65535]]
    """
    if bits not in (8, 16):
        raise InvalidInputError(f"bit depth must be 8 or 16, not {bits}")
    if image.dtype == np.uint8:
        return image if bits == 8 else image.astype(np.uint16) * 257
    if image.dtype == np.uint16:
        return image if bits == 16 else ((image.astype(np.uint32) + 128) // 257).astype(np.uint8)
    raise InvalidInputError(f"cannot write pixel type {image.dtype} (use uint8 or uint16)")


def _png_text_chunk(key: str, value: str) -> bytes:
    payload = key.encode("latin-1") + b"\x00" + value.encode("latin-1")
    body = b"tEXt" + payload
    return struct.pack(">I", len(payload)) + body + struct.pack(">I", zlib.crc32(body))


def encode_png(
    image: np.ndarray,
    *,
    bits: int | None = None,
    text: dict[str, str] | None = None,
    compression: int = 1,
    channel_order: str = "rgb",
) -> bytes:
    """Encode an ``(H, W[, C])`` uint8/uint16 array as PNG bytes.

    Parameters
    ----------
    image : ndarray of uint8 or uint16, shape (H, W) or (H, W, C)
        Grey, RGB or RGBA (packed maps such as Unity's mask map use the alpha channel).
    bits : {8, 16}, optional
        Convert to this depth first (:func:`to_bits`); default: the array's own.
    text : dict of str to str, optional
        tEXt metadata (latin-1).
    compression : int, default 1
        zlib's level (0-9); on photographic textures level 1 gives files within 1 % of level 6's
        size in half the time.
    channel_order : {"rgb", "bgr"}, default "rgb"
        The order of ``image``'s colour channels: ``"bgr"`` (OpenCV's own) is encoded without a
        reordered copy (a large image's).

    Returns
    -------
    bytes

    Raises
    ------
    InvalidInputError
        Another pixel type or shape.
    """
    import cv2

    if channel_order not in ("rgb", "bgr"):
        raise InvalidInputError(f"channel_order must be rgb or bgr, not {channel_order!r}")

    arr = np.asarray(image)
    if bits is not None:
        arr = to_bits(arr, bits)
    if arr.dtype not in (np.uint8, np.uint16):
        raise InvalidInputError(f"cannot write pixel type {arr.dtype} (use uint8 or uint16)")
    if arr.ndim == 3 and arr.shape[2] == 1:
        arr = arr[:, :, 0]
    if arr.ndim == 3:
        if arr.shape[2] not in (3, 4):
            raise InvalidInputError(f"cannot write an image with {arr.shape[2]} channels")
        if channel_order == "rgb":
            arr = arr[:, :, [2, 1, 0, 3][: arr.shape[2]]]  # OpenCV writes BGR(A)
    ok, buf = cv2.imencode(".png", np.ascontiguousarray(arr), [cv2.IMWRITE_PNG_COMPRESSION, int(compression)])
    del arr  # (a reordered copy: not held beside the encoded bytes)
    if not ok:
        raise InvalidInputError("PNG encoding failed")
    data = buf.tobytes()
    del buf
    if text:
        ihdr_end = 8 + 4 + 4 + 13 + 4
        extra = b"".join(_png_text_chunk(k, v) for k, v in text.items())
        data = data[:ihdr_end] + extra + data[ihdr_end:]
    return data


def encode_concurrently(jobs: dict[str, Callable[[], bytes]]) -> dict[str, bytes]:
    """Run file encoders (``name -> job()``, e.g. :func:`encode_png` of one map) on a pool of
    threads, one per core (zlib and OpenCV's encoder let go of the interpreter while they
    compress, and a run writes a dozen maps); returns ``name -> bytes`` in the jobs' order."""
    from barkgen._shared.threads import worker_pool

    workers = max(1, min(len(jobs), os.cpu_count() or 1))
    if workers == 1:
        return {name: job() for name, job in jobs.items()}
    with worker_pool(workers) as pool:
        futures = {name: pool.submit(job) for name, job in jobs.items()}
        return {name: future.result() for name, future in futures.items()}


def read_png_text(path: str | os.PathLike) -> dict[str, str]:
    """The tEXt metadata of a PNG file (empty for other formats).

    Parameters
    ----------
    path : str or PathLike
        The file.

    Returns
    -------
    dict of str to str
    """
    data = _check_file(Path(path))
    out: dict[str, str] = {}
    if not data.startswith(_PNG_MAGIC):
        return out
    pos = 8
    while pos + 8 <= len(data):
        (length,) = struct.unpack(">I", data[pos : pos + 4])
        ctype = data[pos + 4 : pos + 8]
        if ctype == b"tEXt":
            key, _, value = data[pos + 8 : pos + 8 + length].partition(b"\x00")
            out[key.decode("latin-1")] = value.decode("latin-1")
        if ctype in (b"IDAT", b"IEND"):
            break
        pos += 12 + length
    return out


def write_png(
    path: str | os.PathLike,
    image: np.ndarray,
    *,
    bits: int | None = None,
    text: dict[str, str] | None = None,
) -> Path:
    """Write an image as an 8- or 16-bit PNG, atomically.

    Parameters
    ----------
    path : str or PathLike
        The file.
    image : ndarray of uint8 or uint16, shape (H, W) or (H, W, C)
        The image.
    bits : {8, 16}, optional
        Depth of the file; default: the array's own (uint8 -> 8, uint16 -> 16).
    text : dict of str to str, optional
        tEXt metadata.

    Returns
    -------
    Path
        ``path``.

    Examples
    --------
    >>> import numpy as np, tempfile, os
    >>> out = write_png(os.path.join(tempfile.mkdtemp(), "grey.png"), np.zeros((4, 6), np.uint8))
    >>> read_image(out).shape
    (4, 6, 1)
    """
    return write_bytes_atomic(path, encode_png(image, bits=bits, text=text))
