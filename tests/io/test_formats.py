"""Every common image read, bounded (issue 67): PPM/PGM, TGA, OpenEXR, Radiance HDR and TIFF of
8, 16 and 32 bits, each made here by Pillow, OpenCV, tifffile or OpenEXR, read back and compared;
each refused from its header when it declares too many pixels; a photo read from a pipe."""

from __future__ import annotations

import os
import struct
import subprocess
import sys
import threading
import warnings

import numpy as np
import pytest
from conftest import run
from PIL import Image

from barkgen.errors import ImageReadError, ImageTooLargeError
from barkgen.io import AlphaDroppedWarning, ImageContentWarning, decode_image, image_size, read_image
from barkgen.io import images as images_module

RNG = np.random.default_rng(67)
RGB8 = RNG.integers(0, 256, (12, 17, 3), dtype=np.uint8)
RGB16 = RNG.integers(0, 65536, (12, 17, 3), dtype=np.uint16)


def _srgb(v: np.ndarray) -> np.ndarray:
    """IEC 61966-2-1's encoding, written out here apart from the reader's."""
    return np.where(v <= 0.0031308, 12.92 * v, 1.055 * v ** (1 / 2.4) - 0.055)


def _tone_mapped(linear: np.ndarray) -> np.ndarray:
    """What the reader's docstring promises for a float photo: the 99.5th percentile of each
    pixel's brightest channel is white, then the sRGB curve, 16 bits."""
    white = np.percentile(linear.astype(np.float64).max(axis=2), 99.5)
    return np.round(_srgb(np.clip(linear / white, 0, 1)) * 65535).astype(np.uint16)


# ------------------------------------------------------------------------ PPM / PGM


@pytest.mark.parametrize("kind", ["ppm", "pgm"])
@pytest.mark.parametrize("bits", [8, 16])
def test_ppm_and_pgm_of_8_and_16_bits_read_exactly(tmp_path, kind, bits):
    import cv2

    pixels = RGB8 if bits == 8 else RGB16
    if kind == "pgm":
        pixels = pixels[:, :, :1]
    path = tmp_path / f"a.{kind}"
    assert cv2.imwrite(str(path), pixels[:, :, ::-1] if kind == "ppm" else pixels[:, :, 0])
    assert path.read_bytes()[:2] == (b"P6" if kind == "ppm" else b"P5")
    back = read_image(path)
    assert back.dtype == pixels.dtype and np.array_equal(back, pixels)
    assert image_size(path) == (17, 12)


def test_a_pgm_of_another_maxval_is_scaled_to_its_depth(tmp_path):
    path = tmp_path / "ten_bits.pgm"
    path.write_bytes(b"P5\n# a comment\n2 1\n1023\n" + struct.pack(">HH", 0, 1023))
    assert read_image(path)[..., 0].tolist() == [[0, 65535]]


def test_pillow_writes_a_ppm_read_exactly(tmp_path):
    Image.fromarray(RGB8).save(tmp_path / "a.ppm")
    assert np.array_equal(read_image(tmp_path / "a.ppm"), RGB8)


# ------------------------------------------------------------------------ TGA


@pytest.mark.parametrize("mode", ["L", "RGB", "RGBA"])
@pytest.mark.parametrize("compression", [None, "tga_rle"])
def test_tga_of_8_24_and_32_bits_uncompressed_and_rle(tmp_path, mode, compression):
    pixels = {"L": RGB8[:, :, 0], "RGB": RGB8, "RGBA": np.dstack([RGB8, RGB8[:, :, 0]])}[mode]
    path = tmp_path / "bark.tga"
    Image.fromarray(pixels, mode).save(path, **({"compression": compression} if compression else {}))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        back = read_image(path)
    expected = pixels[:, :, None] if mode == "L" else pixels[:, :, :3]
    assert back.dtype == np.uint8 and np.array_equal(back, expected)
    assert any(issubclass(w.category, AlphaDroppedWarning) for w in caught) == (mode == "RGBA")
    assert image_size(path) == (17, 12)


def test_a_text_file_is_not_taken_for_a_tga(tmp_path):
    """TGA has no magic number: a header whose fields disagree (or whose pixels are missing) is no TGA."""
    path = tmp_path / "notes.tga"
    path.write_bytes(b"hello, I am not an image\n" * 4)
    with pytest.raises(ImageReadError, match="not an image"):
        read_image(path)
    truncated = tmp_path / "short.tga"
    Image.fromarray(RGB8).save(truncated)
    truncated.write_bytes(truncated.read_bytes()[:100])  # uncompressed, its pixels missing
    with pytest.raises(ImageReadError, match="not an image"):
        read_image(truncated)


# ------------------------------------------------------------------------ OpenEXR


def _write_exr(path, channels: dict[str, np.ndarray]) -> None:
    import OpenEXR

    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, {k: np.ascontiguousarray(v, np.float32) for k, v in channels.items()}) as exr:
        exr.write(str(path))


def test_an_exr_photo_is_tone_mapped_as_documented(tmp_path):
    pytest.importorskip("OpenEXR")
    linear = (RNG.random((12, 17, 3)) * 6).astype(np.float32)
    _write_exr(tmp_path / "photo.exr", {"R": linear[..., 0], "G": linear[..., 1], "B": linear[..., 2]})
    back = read_image(tmp_path / "photo.exr")
    assert back.dtype == np.uint16 and np.array_equal(back, _tone_mapped(linear))
    assert image_size(tmp_path / "photo.exr") == (17, 12)


def test_barkgen_own_displacement_exr_is_read_back_linear(tmp_path):
    """``NAME_Displacement.exr`` (``--exr-height``) as an ``--extra``: its values, 0-1, as 16 bits."""
    pytest.importorskip("OpenEXR")
    from barkgen.io.material import encode_exr

    height = RNG.random((12, 17)).astype(np.float32)
    (tmp_path / "h.exr").write_bytes(encode_exr(height))
    back = read_image(tmp_path / "h.exr", linear=True)
    assert back.shape == (12, 17, 1) and np.array_equal(
        back[..., 0], np.round(height.astype(np.float64) * 65535).astype(np.uint16)
    )


def test_an_exr_height_outside_0_1_is_scaled_from_its_range_with_a_warning(tmp_path):
    pytest.importorskip("OpenEXR")
    height = np.linspace(-2.0, 3.0, 12 * 17, dtype=np.float32).reshape(12, 17)  # centimetres
    _write_exr(tmp_path / "h.exr", {"Y": height})
    with pytest.warns(ImageContentWarning, match="scaled linearly"):
        back = read_image(tmp_path / "h.exr", linear=True)
    assert np.array_equal(back[..., 0], np.round((height + 2.0) / 5.0 * 65535).astype(np.uint16))


def test_a_scanned_set_with_an_exr_displacement(tmp_path):
    pytest.importorskip("OpenEXR")
    from barkgen.io import read_scanned_set
    from barkgen.io.material import encode_exr

    height = RNG.random((12, 17)).astype(np.float32)
    Image.fromarray(RGB8).save(tmp_path / "Bark001_Color.png")
    (tmp_path / "Bark001_Displacement.exr").write_bytes(encode_exr(height))
    scan = read_scanned_set(tmp_path)
    assert scan.files["height"] == "Bark001_Displacement.exr"
    assert np.abs(scan.height - height).max() <= 0.5 / 65535 + 1e-7


def test_an_exr_without_the_extra_is_one_line(tmp_path, monkeypatch):
    from barkgen._shared import extras
    from barkgen.errors import MissingExtraError

    monkeypatch.setattr(extras, "missing_modules", lambda extra: ["OpenEXR"] if extra == "exr" else [])
    data = b"\x76\x2f\x31\x01\x02\x00\x00\x00" + b"\x00" * 8
    with pytest.raises(MissingExtraError, match=r"\[exr\]"):
        decode_image(data, "h.exr")


# ------------------------------------------------------------------------ Radiance HDR


def test_an_hdr_photo_is_tone_mapped_and_an_hdr_map_kept_linear(tmp_path):
    import cv2

    linear = (RNG.random((12, 17, 3)) * 5).astype(np.float32)
    path = tmp_path / "sky.hdr"
    assert cv2.imwrite(str(path), linear[:, :, ::-1])
    assert path.read_bytes().startswith(b"#?RADIANCE")
    stored = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)[:, :, ::-1]  # (RGBE: 8-bit mantissas)
    assert np.array_equal(read_image(path), _tone_mapped(stored))
    assert image_size(path) == (17, 12)
    small = (stored / stored.max()).astype(np.float32)
    assert cv2.imwrite(str(tmp_path / "map.hdr"), small[:, :, ::-1])
    stored_small = cv2.imread(str(tmp_path / "map.hdr"), cv2.IMREAD_UNCHANGED)[:, :, ::-1].astype(np.float64)
    assert stored_small.max() <= 1.0
    assert np.array_equal(
        read_image(tmp_path / "map.hdr", linear=True), np.round(stored_small * 65535).astype(np.uint16)
    )


# ------------------------------------------------------------------------ TIFF


@pytest.mark.parametrize("depth", ["uint8", "uint16", "float32", "uint32"])
def test_tiff_of_8_16_and_32_bits(tmp_path, depth):
    import tifffile

    source = {
        "uint8": RGB8,
        "uint16": RGB16,
        "float32": RNG.random((12, 17, 3)).astype(np.float32),
        "uint32": RNG.integers(0, 2**32, (12, 17), dtype=np.uint32),
    }[depth]
    tifffile.imwrite(tmp_path / "a.tif", source, photometric="rgb" if source.ndim == 3 else None)
    back = read_image(tmp_path / "a.tif")
    if depth == "float32":  # as before: values 0-1 onto 16 bits, for a photo and a map alike
        expected = np.round(source * 65535.0).astype(np.uint16)
        assert np.array_equal(read_image(tmp_path / "a.tif", linear=True), expected)
    elif depth == "uint32":
        expected = np.round(source.astype(np.float64) * (65535 / (2**32 - 1))).astype(np.uint16)[:, :, None]
    else:
        expected = source
    assert back.dtype == expected.dtype and np.array_equal(back, expected)


# ------------------------------------------------------------------------ bounded before decoding


def _exr_header_declaring(width: int, height: int) -> bytes:
    box = struct.pack("<iiii", 0, 0, width - 1, height - 1)
    attribute = b"dataWindow\x00box2i\x00" + struct.pack("<i", 16) + box
    return b"\x76\x2f\x31\x01\x02\x00\x00\x00" + attribute + b"\x00" + b"\x00" * 64


HUGE = {  # headers declaring 100,000 x 100,000 pixels, with no pixels behind them
    "ppm": b"P6\n100000 100000\n255\n" + b"\x00" * 64,
    "pgm": b"P5\n100000 100000\n65535\n" + b"\x00" * 64,
    "tga rle": struct.pack("<BBBHHBHHHHBB", 0, 0, 10, 0, 0, 0, 0, 0, 50000, 50000, 24, 0) + b"\x00" * 64,
    "exr": _exr_header_declaring(100_000, 100_000),
    "hdr": b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 100000 +X 100000\n" + b"\x00" * 64,
}


@pytest.mark.parametrize("kind", sorted(HUGE))
def test_a_header_declaring_a_huge_image_is_refused_before_decoding(tmp_path, kind, monkeypatch):
    from barkgen.io import image_formats

    def never(*args, **kwargs):
        raise AssertionError("decoded")

    for name in ("decode_pnm", "decode_tga", "decode_exr", "decode_hdr"):
        monkeypatch.setattr(image_formats, name, never)
    with pytest.raises(ImageTooLargeError, match="megapixels"):
        decode_image(HUGE[kind], kind, max_pixels=50_000_000)
    path = tmp_path / "huge.bin"
    path.write_bytes(HUGE[kind])
    width, height = image_size(path)
    assert width * height >= 2.5e9
    r = run("--max-pixels", "1000000", "labels", str(path), "-o", str(tmp_path / "l.png"), "-q")
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1 and "megapixels" in r.stderr, r.stderr


# ------------------------------------------------------------------------ pipes


def _synth(source: str, stdin: bytes, out) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "barkgen", "synth", source, "-o", str(out), "--size", "48x48", "-q"],
        input=stdin,
        capture_output=True,
        timeout=300,
    )


@pytest.fixture(scope="module")
def photo_png(tmp_path_factory):
    path = tmp_path_factory.mktemp("pipe") / "photo.png"
    Image.fromarray(RNG.integers(0, 256, (48, 48, 3), dtype=np.uint8)).save(path)
    return path


@pytest.mark.parametrize("source", ["-", "/dev/stdin"])
def test_a_photo_through_a_pipe_is_read_as_its_file_is(tmp_path, photo_png, source):
    r = _synth(source, photo_png.read_bytes(), tmp_path / "piped.png")
    assert r.returncode == 0, r.stderr
    assert run("synth", str(photo_png), "-o", str(tmp_path / "file.png"), "--size", "48x48", "-q").returncode == 0
    assert (tmp_path / "piped.png").read_bytes() == (tmp_path / "file.png").read_bytes()


def test_a_tga_through_a_pipe(tmp_path):
    import io

    buf = io.BytesIO()
    Image.fromarray(RNG.integers(0, 256, (48, 48, 3), dtype=np.uint8)).save(buf, "TGA", compression="tga_rle")
    r = _synth("-", buf.getvalue(), tmp_path / "o.png")
    assert r.returncode == 0, r.stderr


@pytest.mark.parametrize("case", ["too many pixels", "not an image", "empty"])
def test_a_pipe_refused_in_one_line(tmp_path, photo_png, case):
    data = {"too many pixels": photo_png.read_bytes(), "not an image": b"hello\n" * 1000, "empty": b""}[case]
    args = ["--max-pixels", "1000"] if case == "too many pixels" else []
    r = subprocess.run(
        [sys.executable, "-m", "barkgen", *args, "synth", "-", "-o", str(tmp_path / "o.png"), "-q"],
        input=data,
        capture_output=True,
        timeout=300,
    )
    lines = r.stderr.decode().strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1 and lines[0].startswith("barkgen: error: "), r.stderr
    assert {"too many pixels": "megapixels", "not an image": "not an image", "empty": "0 bytes"}[case] in lines[0]
    assert not (tmp_path / "o.png").exists()


def test_a_pipe_over_the_byte_limit_is_refused_once_past_it_not_read_whole(photo_png, monkeypatch):
    """The limit is the file reader's (MAX_IMAGE_BYTES), made small here; the writer still has
    bytes to give when the reader refuses."""
    limit = 64 * 1024
    monkeypatch.setattr(images_module, "MAX_IMAGE_BYTES", limit)
    payload = photo_png.read_bytes() + bytes(8 * limit)  # a PNG followed by more than the limit
    read_fd, write_fd = os.pipe()
    written = []

    def writer():
        try:
            with os.fdopen(write_fd, "wb") as out:
                for start in range(0, len(payload), 4096):
                    out.write(payload[start : start + 4096])
                    out.flush()
                    written.append(4096)
        except BrokenPipeError:
            pass

    thread = threading.Thread(target=writer, daemon=True)
    thread.start()
    try:
        with pytest.raises(ImageTooLargeError, match="stopped there") as refused:
            read_image(f"/proc/self/fd/{read_fd}")
    finally:
        os.close(read_fd)
        thread.join(10)
    assert "\n" not in str(refused.value)
    assert sum(written) < len(payload)  # (the pipe's buffer holds 64 KiB: the rest was never read)


def test_generate_takes_an_exr_extra_as_the_16_bit_png_of_its_values(tmp_path):
    """``generate --extra height=h.exr`` (barkgen's own ``NAME_Displacement.exr``) makes what
    the 16-bit PNG of the same heights makes: kept linear, not tone-mapped."""
    pytest.importorskip("OpenEXR")
    from barkgen.io import write_png
    from barkgen.io.material import encode_exr

    height = RNG.random((48, 48)).astype(np.float32)
    (tmp_path / "h.exr").write_bytes(encode_exr(height))
    write_png(tmp_path / "h.png", np.round(height.astype(np.float64) * 65535).astype(np.uint16))
    photo = tmp_path / "photo.png"
    Image.fromarray(RNG.integers(0, 256, (48, 48, 3), dtype=np.uint8)).save(photo)
    for name in ("exr", "png"):
        extra = f"height={tmp_path / f'h.{name}'}"
        r = run("generate", str(photo), "--extra", extra, "-o", str(tmp_path / name), "--size", "48x48", "-q")
        assert r.returncode == 0, r.stderr
    for output in ("texture.png", "height.png"):
        assert np.array_equal(read_image(tmp_path / "exr" / output), read_image(tmp_path / "png" / output))


# ------------------------------------------------------------------------ past Pillow's own limit


def test_a_png_past_pillows_own_limit_is_read_as_barkgens_own_16k_maps_are(tmp_path, monkeypatch):
    """Pillow refuses any image over twice its ``MAX_IMAGE_PIXELS`` (179 megapixels), so barkgen
    could not read its own 16384² maps back (issue 69). A PNG past that limit is decoded by
    OpenCV instead (8 and 16 bits, grey, RGB and RGBA alike) and measured from its header; barkgen's
    own ``max_pixels`` still refuses it. Pillow's limit is lowered here to make a small image
    past it."""
    import cv2

    monkeypatch.setattr(Image, "MAX_IMAGE_PIXELS", 50)  # (its error from 100 px on)
    rgba = np.dstack([RGB16, RNG.integers(0, 65536, (12, 17), dtype=np.uint16)])
    for name, pixels in {"rgb8": RGB8, "rgb16": RGB16, "grey8": RGB8[:, :, 0], "rgba16": rgba}.items():
        path = tmp_path / f"{name}.png"
        bgr = pixels if pixels.ndim == 2 else pixels[:, :, [2, 1, 0, 3][: pixels.shape[2]]]
        assert cv2.imwrite(str(path), bgr)
        with pytest.raises(Image.DecompressionBombError):
            Image.open(path)
        assert image_size(path) == (17, 12)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", AlphaDroppedWarning)
            read = read_image(path)
        expected = pixels[:, :, None] if pixels.ndim == 2 else pixels[:, :, :3]
        assert read.dtype == pixels.dtype and np.array_equal(read, expected), name
        with pytest.raises(ImageTooLargeError, match="megapixels"):
            decode_image(path.read_bytes(), name, max_pixels=100)
    jpeg = tmp_path / "photo.jpg"
    assert cv2.imwrite(str(jpeg), RGB8)  # (a JPEG past it is still refused: Pillow reads it)
    with pytest.raises(ImageTooLargeError, match="too large"):
        read_image(jpeg)
