"""barkgen.io.streaming: PNG and EXR maps written band by band (issue 69), read back exactly,
through a staged temporary that leaves nothing at the target on an error."""

from __future__ import annotations

import hashlib
import io
import os
import struct
import zlib

import numpy as np
import pytest
from conftest import BARK, BARK_MAPS
from PIL import Image

import barkgen.io.streaming as streaming
from barkgen.errors import InvalidInputError
from barkgen.io import (
    ExrStream,
    PngStream,
    commit_staged,
    decode_image,
    discard_staged,
    encode_png,
    read_image,
    read_png_text,
)
from barkgen.io.staging import TEMPORARY_NAME, current_umask
from barkgen.io.streaming import filter_rows

UNEVEN_BANDS = [1, 5, 0, 10, 2, 5]  # 23 rows


def mixed_image(height: int, width: int, channels: int, dtype) -> np.ndarray:
    """Noise, ramps and repeated rows: content on which every filter type wins somewhere."""
    rng = np.random.default_rng(height * width + channels)
    top = np.iinfo(dtype).max
    image = rng.integers(0, top, (height, width, channels), dtype=np.int64, endpoint=True)
    image[: height // 3] = np.linspace(0, top, width, dtype=np.int64)[None, :, None]
    image[height // 2 :] = (image[height // 2 :] // 64 + np.arange(height - height // 2)[:, None, None] * 3) % top
    return image.astype(dtype)


def write_in_bands(target, image: np.ndarray, bands=UNEVEN_BANDS, **options) -> PngStream:
    height, width = image.shape[:2]
    channels = image.shape[2] if image.ndim == 3 else 1
    with PngStream(target, width, height, channels=channels, bits=image.dtype.itemsize * 8, **options) as png:
        start = 0
        for rows in bands:
            png.write(image[start : start + rows])
            start += rows
    return png


def chunks(data: bytes) -> list[tuple[bytes, bytes]]:
    """(type, data) of every chunk of a PNG file, each CRC checked."""
    pos, out = 8, []
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos : pos + 4])
        kind, body = data[pos + 4 : pos + 8], data[pos + 8 : pos + 8 + length]
        assert struct.unpack(">I", data[pos + 8 + length : pos + 12 + length])[0] == zlib.crc32(kind + body)
        out.append((kind, body))
        pos += 12 + length
    return out


def decoded(path) -> np.ndarray:
    """A PNG file's pixels as OpenCV decodes them, alpha kept, in RGB(A) order, ``(H, W, C)``."""
    import cv2

    image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if image.ndim == 2:
        return image[:, :, None]
    return image[:, :, [2, 1, 0, 3][: image.shape[2]]]


def leftovers(folder) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


@pytest.mark.parametrize("bits", [8, 16])
@pytest.mark.parametrize("channels", [1, 3, 4])
def test_png_round_trip_in_uneven_bands(tmp_path, bits, channels):
    image = mixed_image(23, 37, channels, np.uint8 if bits == 8 else np.uint16)
    write_in_bands(tmp_path / "a.png", image)
    assert np.array_equal(decoded(tmp_path / "a.png"), image)
    if channels != 4:  # barkgen's own reader drops alpha
        assert np.array_equal(read_image(tmp_path / "a.png"), image)
    with Image.open(tmp_path / "a.png") as pil:  # a second decoder: Pillow's
        assert pil.size == (37, 23)
        if bits == 8:
            assert np.array_equal(np.asarray(pil).reshape(image.shape), image)
    assert leftovers(tmp_path) == ["a.png"]


def test_grey_rows_may_be_two_dimensional(tmp_path):
    image = mixed_image(23, 9, 1, np.uint16)[:, :, 0]
    write_in_bands(tmp_path / "g.png", image)
    assert np.array_equal(read_image(tmp_path / "g.png")[:, :, 0], image)


def reference_filter(rows: np.ndarray, previous: np.ndarray, bpp: int) -> np.ndarray:
    """The PNG specification's five filters and libpng's choice, byte by byte."""
    out, prior = [], [int(v) for v in previous]
    for row in rows.tolist():
        candidates = [[], [], [], [], []]
        for i, x in enumerate(row):
            a = row[i - bpp] if i >= bpp else 0
            b = prior[i]
            c = prior[i - bpp] if i >= bpp else 0
            p = a + b - c
            pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
            paeth = a if pa <= pb and pa <= pc else b if pb <= pc else c
            for kind, predicted in enumerate([0, a, b, (a + b) // 2, paeth]):
                candidates[kind].append((x - predicted) % 256)
        costs = [sum(min(v, 256 - v) for v in c) for c in candidates]
        best = costs.index(min(costs))
        out.append([best, *candidates[best]])
        prior = row
    return np.array(out, np.uint8)


@pytest.mark.parametrize("bpp", [1, 3, 8])
def test_filters_are_the_specifications(bpp):
    rows = mixed_image(12, 7 * bpp, 1, np.uint8)[:, :, 0]
    previous = np.random.default_rng(bpp).integers(0, 256, rows.shape[1], dtype=np.uint8)
    filtered = filter_rows(rows, previous, bpp)
    assert np.array_equal(filtered, reference_filter(rows, previous, bpp))


def test_filter_types_vary_on_a_photo():
    photo = read_image(BARK / "pine_plated_01.jpg")[:256, :256]
    buffer = io.BytesIO()
    write_in_bands(buffer, photo, bands=[100, 156])
    raw = zlib.decompress(b"".join(body for kind, body in chunks(buffer.getvalue()) if kind == b"IDAT"))
    assert len(set(raw[:: 256 * 3 + 1])) >= 2  # one filter type byte per row, chosen per row


def test_text_and_sha256(tmp_path):
    image = mixed_image(23, 11, 3, np.uint8)
    text = {"Software": "barkgen", "Comment": "écorce 16384²"[:-1]}
    png = write_in_bands(tmp_path / "t.png", image, text=text)
    assert read_png_text(tmp_path / "t.png") == text
    assert png.sha256 == hashlib.sha256((tmp_path / "t.png").read_bytes()).hexdigest()
    buffer = io.BytesIO()  # an open file: written as it is, left open
    on_file = write_in_bands(buffer, image, text=text)
    assert not buffer.closed and on_file.sha256 == png.sha256
    assert buffer.getvalue() == (tmp_path / "t.png").read_bytes()


def test_idat_chunks_are_bounded_and_written_as_they_come(tmp_path, monkeypatch):
    monkeypatch.setattr(streaming, "IDAT_BYTES", 4096)
    image = np.random.default_rng(1).integers(0, 256, (400, 200, 3), dtype=np.uint8)
    png = PngStream(tmp_path / "n.png", 200, 400)
    png.write(image[:300])
    (temporary,) = [p for p in tmp_path.iterdir() if TEMPORARY_NAME.match(p.name)]
    assert temporary.stat().st_size > 100_000  # on disk before the last band
    png.write(image[300:])
    png.close()
    sizes = [len(body) for kind, body in chunks((tmp_path / "n.png").read_bytes()) if kind == b"IDAT"]
    assert len(sizes) > 10 and max(sizes) == 4096
    assert np.array_equal(read_image(tmp_path / "n.png"), image)


def normal_map(grey: np.ndarray) -> np.ndarray:
    gy, gx = np.gradient(grey.astype(np.float32))
    normal = np.dstack([-gx, gy, np.full_like(gx, 16.0)])
    normal /= np.linalg.norm(normal, axis=2, keepdims=True)
    return np.round((normal * 0.5 + 0.5) * 255).astype(np.uint8)


@pytest.mark.parametrize("name", ["photo", "scanned normal", "made normal", "height16"])
def test_size_close_to_encode_png(name):
    photo = read_image(BARK / "oak_furrowed_moss_01.jpg")[:512, :512]
    image = {
        "photo": lambda: photo,
        "scanned normal": lambda: read_image(BARK_MAPS / "oak_furrowed_moss_01_normal.jpg")[:512, :512],
        "made normal": lambda: normal_map(photo.mean(axis=2)),
        "height16": lambda: (photo.mean(axis=2, keepdims=True) * 257).astype(np.uint16),
    }[name]()
    buffer = io.BytesIO()
    write_in_bands(buffer, image, bands=[64] * 8)
    assert np.array_equal(decode_image(buffer.getvalue()).reshape(image.shape), image)
    assert len(buffer.getvalue()) <= 1.10 * len(encode_png(image))


def test_row_count_is_checked(tmp_path):
    image = mixed_image(23, 11, 3, np.uint8)
    with pytest.raises(InvalidInputError, match="22 of its 23 rows"):
        write_in_bands(tmp_path / "short.png", image, bands=[10, 12])
    with pytest.raises(InvalidInputError, match=r"4 more rows would pass the PNG's height 23 \(20 written\)"):
        with PngStream(tmp_path / "long.png", 11, 23) as png:
            png.write(image[:20])
            png.write(image[:4])
    png = PngStream(tmp_path / "plain.png", 11, 23)
    png.write(image[:5])
    with pytest.raises(InvalidInputError, match="5 of its 23 rows"):
        png.close()
    with pytest.raises(InvalidInputError, match="aborted"):
        png.write(image[5:])
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize(
    ("rows", "message"),
    [
        (np.zeros((2, 11, 3), np.uint16), "takes uint8 rows, not uint16"),
        (np.zeros((2, 11, 3), np.float32), "takes uint8 rows, not float32"),
        (np.zeros((2, 12, 3), np.uint8), r"bands of shape \(n, 11, 3\), not \(2, 12, 3\)"),
        (np.zeros((2, 11), np.uint8), r"bands of shape \(n, 11, 3\)"),
    ],
)
def test_wrong_band_refused_and_nothing_left(tmp_path, rows, message):
    (tmp_path / "keep.png").write_bytes(b"the old file")
    with pytest.raises(InvalidInputError, match=message) as caught:
        with PngStream(tmp_path / "keep.png", 11, 23) as png:
            png.write(np.zeros((3, 11, 3), np.uint8))
            png.write(rows)
    assert "\n" not in str(caught.value)
    assert leftovers(tmp_path) == ["keep.png"] and (tmp_path / "keep.png").read_bytes() == b"the old file"


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"channels": 2}, "1, 3 or 4 channels"),
        ({"bits": 12}, "8 or 16 bits"),
        ({"compression": 10}, "0 to 9"),
        ({"width": 0}, "cannot write a 0x23 image"),
        ({"text": {"Comment": "树皮"}}, None),
    ],
)
def test_bad_stream_refused_before_anything_is_written(tmp_path, options, message):
    arguments = {"width": 11, "height": 23, **options}
    error = UnicodeEncodeError if message is None else InvalidInputError
    with pytest.raises(error, match=message):
        PngStream(tmp_path / "x.png", **arguments)
    assert leftovers(tmp_path) == []


def test_staged_until_committed(tmp_path):
    image = mixed_image(23, 11, 4, np.uint8)
    folder = tmp_path / "set" / "maps"
    staged: list = []
    png = write_in_bands(folder / "a_Color.png", image, staged=staged)
    made = [target for temporary, target in staged if not temporary]
    ((temporary, target),) = [(t, p) for t, p in staged if t]
    assert made == [tmp_path / "set", folder] and target == folder / "a_Color.png"
    assert TEMPORARY_NAME.match(os.path.basename(temporary)) and not target.exists()
    assert os.stat(temporary).st_mode & 0o777 == 0o666 & ~current_umask()
    commit_staged(staged)
    assert leftovers(folder) == ["a_Color.png"] and np.array_equal(decoded(target), image)
    assert png.sha256 == hashlib.sha256(target.read_bytes()).hexdigest()


def test_staged_then_discarded_leaves_nothing(tmp_path):
    image = mixed_image(23, 11, 3, np.uint8)
    staged: list = []
    write_in_bands(tmp_path / "new" / "a.png", image, staged=staged)
    with pytest.raises(InvalidInputError):
        write_in_bands(tmp_path / "new" / "b.png", image, bands=[3, 4], staged=staged)
    assert leftovers(tmp_path / "new") == [os.path.basename(staged[1][0])]  # a's temporary only
    discard_staged(staged)
    assert leftovers(tmp_path) == []


def test_staged_needs_a_path():
    with pytest.raises(InvalidInputError, match="by its path"):
        PngStream(io.BytesIO(), 4, 4, staged=[])


def test_interrupt_leaves_no_target(tmp_path):
    image = mixed_image(23, 11, 3, np.uint8)
    with pytest.raises(KeyboardInterrupt):
        with PngStream(tmp_path / "a.png", 11, 23) as png:
            png.write(image[:10])
            raise KeyboardInterrupt
    assert leftovers(tmp_path) == []


# -- EXR -------------------------------------------------------------------------------------


def test_exr_round_trip_exact(tmp_path):
    OpenEXR = pytest.importorskip("OpenEXR")
    values = np.random.default_rng(2).normal(0, 3, (41, 29)).astype(np.float32)
    values[0, :4] = [np.inf, -0.0, 1e-40, np.float32(np.pi)]
    with ExrStream(tmp_path / "h.exr", 29, 41) as exr:
        start = 0
        for rows in [1, 15, 0, 17, 8]:
            exr.write(values[start : start + rows] if rows % 2 else values[start : start + rows, :, None])
            start += rows
    with OpenEXR.File(str(tmp_path / "h.exr")) as back:
        assert back.header()["compression"] == OpenEXR.ZIP_COMPRESSION
        (name, channel), *others = back.channels().items()
        assert name == "Y" and not others and channel.pixels.dtype == np.float32
        assert np.array_equal(channel.pixels.view(np.uint32), values.view(np.uint32))
    assert exr.sha256 == hashlib.sha256((tmp_path / "h.exr").read_bytes()).hexdigest()
    assert os.stat(tmp_path / "h.exr").st_mode & 0o777 == 0o666 & ~current_umask()
    assert leftovers(tmp_path) == ["h.exr"]


def test_exr_staged_and_checked(tmp_path):
    pytest.importorskip("OpenEXR")
    values = np.linspace(0, 1, 20 * 8, dtype=np.float64).reshape(20, 8)
    staged: list = []
    with ExrStream(tmp_path / "d.exr", 8, 20, staged=staged) as exr:
        exr.write(values)
    assert not (tmp_path / "d.exr").exists()
    with pytest.raises(InvalidInputError, match="takes float16 or float32 or float64 rows, not uint8"):
        with ExrStream(tmp_path / "e.exr", 8, 20, staged=staged) as bad:
            bad.write(np.zeros((20, 8), np.uint8))
    with pytest.raises(InvalidInputError, match="19 of its 20 rows"):
        with ExrStream(tmp_path / "f.exr", 8, 20) as short:
            short.write(values[:19])
    commit_staged([entry for entry in staged if os.path.exists(entry[0])])
    assert leftovers(tmp_path) == ["d.exr"]
    assert exr.sha256 == hashlib.sha256((tmp_path / "d.exr").read_bytes()).hexdigest()
