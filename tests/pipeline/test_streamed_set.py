"""A material set written as its windows are finished (:mod:`barkgen.pipeline.streamed`, issue
69): the same files as ``encode_material(transfer_material(...))`` writes for the whole output,
pixels within a last bit, records equal, and nothing left when it fails part-way."""

from __future__ import annotations

import hashlib
import json

import numpy as np
import pytest
from conftest import bark_exemplar, shuffled_blocks

from barkgen._shared.canvas import Canvas

HEIGHT, WIDTH, BLOCK, WINDOW = 192, 256, 32, 64
META = {"seed": 7, "source_photo": "fir_scaly_01.jpg", "source": "a key as generate might add"}


@pytest.fixture(scope="module")
def run():
    from barkgen.material import MaterialOptions, make_material, transfer_material

    photo = bark_exemplar("fir_scaly_01", 128)
    source = make_material(photo, MaterialOptions(exemplar_wrap="no"))
    refs = shuffled_blocks((HEIGHT, WIDTH), photo.shape[0], BLOCK, seed=3)
    canvas = Canvas((HEIGHT, WIDTH), tile=True, exemplar_wrap=(False, False))
    whole = transfer_material(source, refs, canvas).with_width_m(0.8)
    return source, refs, canvas, whole


def written_and_expected(run, folder, preset, udim):
    from barkgen.io import encode_material
    from barkgen.pipeline.streamed import write_material_streamed

    source, refs, canvas, whole = run
    hashes = write_material_streamed(
        source, refs, canvas, folder, "bark", preset, width_m=0.8, udim=udim, window=WINDOW, **META
    )
    expected = encode_material(whole, "bark", preset, udim=udim, **META)
    return hashes, expected


def pixels(data: bytes) -> np.ndarray:
    """A PNG's samples as stored (every channel, alpha included)."""
    import cv2

    return cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)


def compare_images(folder, hashes, expected):
    """Every PNG decoded against the whole encoding's: returns file -> (samples equal, samples)."""
    counts = {}
    for file, data in expected.items():
        if not file.endswith(".png"):
            continue
        written = (folder / file).read_bytes()
        got, want = pixels(written), pixels(data)
        assert got.shape == want.shape and got.dtype == want.dtype, file
        diff = np.abs(got.astype(np.int64) - want)
        assert diff.max() <= 1, (file, int(diff.max()))
        counts[file] = (int((diff == 0).sum()), diff.size)
        assert hashes[file] == hashlib.sha256(written).hexdigest()
    return counts


@pytest.mark.parametrize(("preset", "udim"), [("ambientcg", (2, 1)), ("unity", None)])
def test_the_streamed_set_is_the_whole_encoding(run, tmp_path, preset, udim):
    hashes, expected = written_and_expected(run, tmp_path, preset, udim)
    written = sorted(p.name for p in tmp_path.iterdir())
    assert written == sorted(expected) == sorted(hashes)  # no spill, no temporary left
    counts = compare_images(tmp_path, hashes, expected)
    # (measured: the colour, roughness, AO and packed maps all equal, the normals but 1 sample
    # in 10^5, the 16-bit displacement 94 %: the rest one off, the windows' and the whole
    # solve's last bits)
    for file, (equal, total) in counts.items():
        share = 0.9 if ("Displacement" in file or "Height" in file) else 0.9999
        assert equal / total >= share, (file, equal, total)
    got = json.loads((tmp_path / "bark.json").read_text())
    want = json.loads(expected["bark.json"])
    # the displacement's depth and midlevel from the windows' heights (within the solve's last
    # bits); every other entry, the file list included, equal
    for key in ("displacement_depth_px", "displacement_depth", "displacement_midlevel", "displacement_depth_m"):
        assert got.pop(key) == pytest.approx(want.pop(key), rel=1e-4, abs=1e-6), key
    assert got == want
    assert got["files"] == sorted(set(expected) - {"bark.json"})


@pytest.fixture(scope="module")
def windowed(run):
    """The window cores (solved once for the tests that replay them) and the set glued from
    them: the very set the streamed files hold."""
    import dataclasses

    from barkgen.pipeline.windowed import material_in_windows

    source, refs, canvas, whole = run
    cores = list(material_in_windows(source, refs, canvas, window=WINDOW))
    glued = {kind: np.zeros_like(getattr(whole, kind)) for kind in ("color", "height", "normals", "ao", "roughness")}
    for maps in cores:
        for kind, values in glued.items():
            values[maps.target] = getattr(maps.material, kind)
    return cores, dataclasses.replace(whole, **glued)


def streamed_replaying(run, windowed, monkeypatch, folder, preset, **options):
    import barkgen.pipeline.streamed as streamed

    source, refs, canvas, _ = run
    monkeypatch.setattr(streamed, "material_in_windows", lambda *args, **kwargs: iter(windowed[0]))
    return streamed.write_material_streamed(source, refs, canvas, folder, "bark", preset, window=WINDOW, **options)


def test_the_records_are_encode_materials_for_the_set_made_in_windows(run, windowed, tmp_path, monkeypatch):
    """With the very heights of the windows, NAME.json, the Blender set-up and NAME.mtlx are
    byte for byte encode_material's (for the set glued from the window cores), the EXR's
    values and every image's pixels equal."""
    from barkgen.io import encode_material

    pytest.importorskip("MaterialX")
    pytest.importorskip("OpenEXR")
    hashes = streamed_replaying(run, windowed, monkeypatch, tmp_path, "blender", width_m=0.8, exr_height=True)
    expected = encode_material(windowed[1], "bark", "blender", exr_height=True)
    for file in ("bark.json", "bark_blender.py", "bark.mtlx"):
        assert (tmp_path / file).read_bytes() == expected[file], file
    for file, data in expected.items():
        if file.endswith(".png"):  # the same set: the same pixels exactly
            assert np.array_equal(pixels((tmp_path / file).read_bytes()), pixels(data)), file
    from barkgen.io.images import decode_image

    exr = tmp_path / "bark_Displacement.exr"
    assert np.array_equal(
        decode_image(exr.read_bytes(), linear=True), decode_image(expected["bark_Displacement.exr"], linear=True)
    )
    assert sorted(hashes) == sorted(expected)


def test_an_image_packing_the_displacement_is_written_from_the_spill(run, windowed, tmp_path, monkeypatch):
    """A preset that packs the displacement with another map (none does yet): its other
    channels spilled with the heights, the displacement's put in after the last window."""
    import barkgen.material.presets as presets
    from barkgen.io import encode_material

    real = presets.preset_images

    def with_pack(material, name, preset="ambientcg"):
        files = real(material, name, preset)
        maps = presets.encoded_maps(material)
        files[f"{name}_RoughDisp.png"] = presets.pack_channels(maps["roughness"], maps["displacement"], maps["ao"])
        return files

    monkeypatch.setattr(presets, "preset_images", with_pack)
    assert streamed_plan(windowed).packed == {"bark_RoughDisp.png": (1,)}
    streamed_replaying(run, windowed, monkeypatch, tmp_path, "gltf", width_m=0.8, udim=(2, 1))
    expected = encode_material(windowed[1], "bark", "gltf", udim=(2, 1))
    assert "bark_RoughDisp.1002.png" in expected
    for file, data in expected.items():
        if file.endswith(".png"):
            assert np.array_equal(pixels((tmp_path / file).read_bytes()), pixels(data)), file
    assert (tmp_path / "bark.json").read_bytes() == expected["bark.json"]


def streamed_plan(windowed):
    from barkgen.pipeline.streamed import displacement_plan

    return displacement_plan(windowed[0][0].material, "bark", "gltf")


def test_an_error_after_the_first_band_leaves_no_file(run, tmp_path, monkeypatch):
    import barkgen.pipeline.streamed as streamed

    source, refs, canvas, _ = run
    real = streamed.write_band
    bands = []

    def failing(*args, **kwargs):
        bands.append(1)
        if len(bands) == 2:
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    monkeypatch.setattr(streamed, "write_band", failing)
    folder = tmp_path / "new" / "set"
    (tmp_path / "keep.txt").write_text("mine")
    with pytest.raises(KeyboardInterrupt):
        streamed.write_material_streamed(source, refs, canvas, folder, "bark", "gltf", udim=(2, 1), window=WINDOW)
    assert len(bands) == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["keep.txt"]  # the folders made removed too
