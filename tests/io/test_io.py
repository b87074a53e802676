"""barkgen.io: formats, bit depths, alpha, broken files, atomic writes."""

from __future__ import annotations

import os

import numpy as np
import pytest
from PIL import Image

from barkgen.errors import ImageReadError, InvalidInputError
from barkgen.io import AlphaDroppedWarning, read_image, read_png_text, read_reference, write_png, write_reference


@pytest.fixture
def rgb8():
    return np.random.default_rng(0).integers(0, 256, (20, 30, 3), dtype=np.uint8)


def test_png_roundtrip_8_and_16_bit(tmp_path, rgb8):
    write_png(tmp_path / "a.png", rgb8)
    assert np.array_equal(read_image(tmp_path / "a.png"), rgb8)
    rgb16 = rgb8.astype(np.uint16) * 257 + 3
    write_png(tmp_path / "b.png", rgb16)
    back = read_image(tmp_path / "b.png")
    assert back.dtype == np.uint16 and np.array_equal(back, rgb16)
    grey16 = rgb16[:, :, :1]
    write_png(tmp_path / "g.png", grey16)
    assert np.array_equal(read_image(tmp_path / "g.png"), grey16)


def test_bit_depth_conversion_on_write(tmp_path, rgb8):
    write_png(tmp_path / "a.png", rgb8, bits=16)
    back = read_image(tmp_path / "a.png")
    assert back.dtype == np.uint16 and np.array_equal(back, rgb8.astype(np.uint16) * 257)
    write_png(tmp_path / "b.png", back, bits=8)
    assert np.array_equal(read_image(tmp_path / "b.png"), rgb8)


@pytest.mark.parametrize("fmt", ["JPEG", "WEBP", "TIFF"])
def test_other_formats(tmp_path, rgb8, fmt):
    p = tmp_path / f"a.{fmt.lower()}"
    Image.fromarray(rgb8).save(p, fmt, **({"quality": 95} if fmt != "TIFF" else {}))
    img = read_image(p)
    assert img.shape == (20, 30, 3) and img.dtype == np.uint8
    if fmt == "TIFF":
        assert np.array_equal(img, rgb8)


def test_tiff_16_bit(tmp_path, rgb8):
    import tifffile

    data = rgb8.astype(np.uint16) * 200
    tifffile.imwrite(tmp_path / "a.tif", data)
    assert np.array_equal(read_image(tmp_path / "a.tif"), data)


def test_alpha_is_dropped_with_warning(tmp_path, rgb8):
    rgba = np.dstack([rgb8, np.full(rgb8.shape[:2], 128, np.uint8)])
    Image.fromarray(rgba, "RGBA").save(tmp_path / "a.png")
    with pytest.warns(AlphaDroppedWarning):
        img = read_image(tmp_path / "a.png")
    assert np.array_equal(img, rgb8)


@pytest.mark.parametrize("case", ["missing", "empty", "text", "truncated_png", "truncated_jpg", "dir"])
def test_bad_files_raise_one_clear_error(tmp_path, rgb8, case):
    p = tmp_path / "bad.png"
    if case == "empty":
        p.write_bytes(b"")
    elif case == "text":
        p.write_text("hello, I am not an image\n")
    elif case == "truncated_png":
        write_png(tmp_path / "full.png", rgb8)
        p.write_bytes((tmp_path / "full.png").read_bytes()[:200])
    elif case == "truncated_jpg":
        p = tmp_path / "bad.jpg"
        big = np.random.default_rng(1).integers(0, 256, (200, 200, 3), dtype=np.uint8)
        Image.fromarray(big).save(tmp_path / "full.jpg", quality=95)
        p.write_bytes((tmp_path / "full.jpg").read_bytes()[:3000])
    elif case == "dir":
        p = tmp_path
    with pytest.raises(ImageReadError) as err:
        read_image(p)
    assert "\n" not in str(err.value) and str(p) in str(err.value)


def test_write_is_atomic_on_failure(tmp_path, rgb8, monkeypatch):
    target = tmp_path / "out.png"
    write_png(target, rgb8)
    before = target.read_bytes()

    def boom(*a, **k):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", boom)
    with pytest.raises(OSError):
        write_png(target, rgb8[::-1])
    assert target.read_bytes() == before  # old content intact
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.png"]  # no temp file left


def test_reference_map_roundtrip(tmp_path):
    refs = np.stack(np.meshgrid(np.arange(7), np.arange(9), indexing="ij"), -1).astype(np.int32)
    write_reference(tmp_path / "r.png", refs, (300, 400))
    back, shape = read_reference(tmp_path / "r.png")
    assert np.array_equal(back, refs) and shape == (300, 400)
    assert read_png_text(tmp_path / "r.png")["barkgen-reference"] == "exemplar=400x300"


def test_written_files_get_the_usual_permissions(tmp_path, rgb8):
    old = os.umask(0o022)
    try:
        write_png(tmp_path / "a.png", rgb8)
    finally:
        os.umask(old)
    assert (tmp_path / "a.png").stat().st_mode & 0o777 == 0o644


def test_write_files_atomic_leaves_the_old_set_on_failure(tmp_path):
    from barkgen.io import write_files_atomic

    write_files_atomic(tmp_path, {"a.png": b"old a", "b.png": b"old b"})
    with pytest.raises(TypeError):
        write_files_atomic(tmp_path, {"a.png": b"new a", "b.png": b"new b", "c.png": None})
    assert (tmp_path / "a.png").read_bytes() == b"old a" and (tmp_path / "b.png").read_bytes() == b"old b"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.png", "b.png"]
    write_files_atomic(tmp_path, {"a.png": b"new a", "b.png": b"new b"})
    assert (tmp_path / "a.png").read_bytes() == b"new a"


def test_concurrent_encoding_gives_each_file_its_own_bytes_in_order(rgb8):
    from barkgen.io import encode_concurrently, encode_png

    images = {f"m{i}.png": np.roll(rgb8, i, axis=1) for i in range(7)}
    jobs = {name: (lambda img=img: encode_png(img)) for name, img in images.items()}
    files = encode_concurrently(jobs)
    assert list(files) == list(images)
    assert all(files[name] == encode_png(img) for name, img in images.items())
    with pytest.raises(InvalidInputError, match="pixel type"):
        encode_concurrently({"a.png": jobs["m0.png"], "b.png": lambda: encode_png(rgb8 * 0.5)})


def test_an_image_in_opencvs_channel_order_is_encoded_as_the_same_png(rgb8):
    """``channel_order="bgr"`` (issue 69: a large reference map made in OpenCV's order needs no
    reordered copy) gives the very bytes of the RGB image, RGBA too; another order is refused."""
    from barkgen.io import encode_png

    rgba = np.dstack([rgb8, rgb8[:, :, 0]])
    assert encode_png(rgb8[:, :, ::-1].copy(), channel_order="bgr") == encode_png(rgb8)
    assert encode_png(rgba[:, :, [2, 1, 0, 3]].copy(), channel_order="bgr") == encode_png(rgba)
    with pytest.raises(InvalidInputError, match="channel_order"):
        encode_png(rgb8, channel_order="gbr")


def test_exif_orientation_animations_and_float_ranges_are_honoured_or_said():
    """A phone photo stands as its orientation tag says; an animation's later frames and float
    pixels outside 0-1 are named in a warning, not dropped or clipped without a word."""
    import io as _io
    import warnings as _warnings

    from PIL import Image

    from barkgen.io import ImageContentWarning, decode_image

    pixels = np.zeros((20, 40, 3), np.uint8)
    pixels[:, :10] = 255  # a white band on the left of a landscape picture
    buf = _io.BytesIO()
    exif = Image.Exif()
    exif[0x0112] = 6  # "rotate 90 degrees clockwise to view"
    Image.fromarray(pixels).save(buf, format="JPEG", exif=exif, quality=95)
    shown = decode_image(buf.getvalue(), "phone.jpg")
    assert shown.shape[:2] == (40, 20)  # portrait, as the camera meant
    assert shown[:10, :, 0].mean() > 200 and shown[-10:, :, 0].mean() < 50  # the band on top
    from barkgen.io.images import _image_size

    assert _image_size(buf.getvalue(), "phone.jpg") == (20, 40)  # the header's size, turned too

    frames = [Image.fromarray(np.full((8, 8, 3), v, np.uint8)) for v in (10, 200)]
    buf = _io.BytesIO()
    frames[0].save(buf, format="GIF", save_all=True, append_images=frames[1:])
    with pytest.warns(ImageContentWarning, match="2 frames"):
        decode_image(buf.getvalue(), "anim.gif")

    import tifffile

    buf = _io.BytesIO()
    tifffile.imwrite(buf, np.linspace(-1, 3, 64, dtype=np.float32).reshape(8, 8))
    with pytest.warns(ImageContentWarning, match="clipped"):
        decode_image(buf.getvalue(), "height.tif")
    buf = _io.BytesIO()
    tifffile.imwrite(buf, np.linspace(0, 1, 64, dtype=np.float32).reshape(8, 8))
    with _warnings.catch_warnings():
        _warnings.simplefilter("error")
        decode_image(buf.getvalue(), "unit.tif")  # in range: no warning


def test_a_failed_write_names_the_users_file_not_our_temporary(tmp_path, monkeypatch):
    import errno
    import tempfile

    from barkgen.io import write_files_atomic

    def full_disk(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device", str(tmp_path / ".a.png.1.xyz.tmp"))

    monkeypatch.setattr(tempfile, "mkstemp", full_disk)
    with pytest.raises(OSError) as info:
        write_files_atomic(tmp_path, {"a.png": b"x"})
    assert info.value.filename == str(tmp_path / "a.png") and info.value.errno == errno.ENOSPC
    assert list(tmp_path.iterdir()) == []
