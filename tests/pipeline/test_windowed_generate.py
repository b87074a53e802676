"""A run made window by window (issue 69, ``GenerateOptions.windowed``): its material set
made as its files are written: :func:`generate` gives a
:class:`~barkgen.pipeline.WindowedMaterial`, ``barkgen generate`` writes it as its windows are
finished, and the folder is what the whole set's run writes (the same files, each map within a
last bit, ``report.json`` recording every file), never half of it."""

from __future__ import annotations

import hashlib
import json

import numpy as np
import pytest
from conftest import bark_exemplar, run, run_here

from barkgen.pipeline import GenerateOptions

# two windows across (the default core is 1024 px), tileable: the second wraps into the first
SIZE = (160, 1152)


@pytest.fixture(scope="module")
def runs():
    from barkgen.pipeline import WindowedMaterial, analyze_photo, generate

    photo = bark_exemplar("fir_scaly_01", 128)
    options = GenerateOptions(size=SIZE, tile=True, material=True, seed=2, windowed="yes")
    analysis = analyze_photo(photo, options)
    windowed = generate(photo, options, analysis=analysis)
    assert isinstance(windowed.material, WindowedMaterial) and windowed.material.shape == SIZE
    whole = generate(photo, GenerateOptions(**{**vars(options), "windowed": "no"}), analysis=analysis)
    return photo, windowed, whole


def decoded(data: bytes) -> np.ndarray:
    import cv2

    return cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)


def test_the_windowed_run_writes_the_whole_runs_folder(runs, tmp_path):
    from barkgen.io import commit_staged, owned_files
    from barkgen.pipeline import encode_generate, write_windowed_material

    photo, windowed, whole = runs
    naming = {"name": "fir", "variant": "seed2", "udim": (2, 1)}
    staged: list = []
    seen: list[tuple[int, int]] = []
    streamed = write_windowed_material(
        windowed, tmp_path, "fir.jpg", staged=staged, progress=lambda d, t: seen.append((d, t)), **naming
    )
    assert not list(tmp_path.glob("*.png"))  # staged only: nothing in place before the caller commits
    files = encode_generate(photo, windowed, "fir.jpg", streamed=streamed, **naming)
    for name, data in files.items():
        (tmp_path / name).write_bytes(data)
    commit_staged(staged)
    expected = encode_generate(photo, whole, "fir.jpg", **naming)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(expected)  # no spill, no temporary
    assert seen[-1][0] == seen[-1][1] >= 2  # the windows counted
    assert sorted({*owned_files(tmp_path, "report.json"), "report.json"}) == sorted(expected)  # every file recorded
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["windowed"] == "yes"
    for name, data in expected.items():
        written = (tmp_path / name).read_bytes()
        assert name == "report.json" or report["file_sha256"][name] == hashlib.sha256(written).hexdigest()
        if name in streamed and name.endswith(".png"):
            diff = np.abs(decoded(written).astype(np.int64) - decoded(data))
            assert diff.max() <= 1, name  # the windows' last bits
        elif name in streamed and name.endswith(".json"):  # the set's record: depth from the windows' heights
            got, want = json.loads(written), json.loads(data)
            for key in [k for k in want if k.startswith("displacement_")]:
                assert got.pop(key) == pytest.approx(want.pop(key), rel=1e-4, abs=1e-6), key
            assert got == want
        elif name not in streamed and name != "report.json":
            assert written == data, name  # the run's own files: the same bytes
    assert "illumination.png" in streamed and "fir_seed2_576x160_Color.1002.png" in streamed


def test_encode_generate_makes_a_windowed_set_whole_without_its_files(runs):
    from barkgen.pipeline import encode_generate

    photo, windowed, whole = runs
    got, want = encode_generate(photo, windowed, "p.jpg"), encode_generate(photo, whole, "p.jpg")
    assert sorted(got) == sorted(want)
    assert all(got[name] == want[name] for name in want if name != "report.json")


@pytest.mark.parametrize(
    ("flags", "needs"),
    [
        (["--sizes", "512"], "--sizes needs the whole material set"),
        (["--model", "bilayer"], "a bi-layer texture is made whole"),
    ],
)
def test_yes_is_refused_where_the_set_must_be_whole(tmp_path, flags, needs):
    from barkgen.data import sample_exemplar_path

    done = run_here(
        "generate", str(sample_exemplar_path()), "-o", str(tmp_path / "out"), "--material", "--windowed", "yes",
        *flags,
    )  # fmt: skip
    assert done.returncode != 0 and needs in done.stderr and "Traceback" not in done.stderr
    assert not (tmp_path / "out").exists()


def test_the_cli_writes_a_windowed_set_and_leaves_nothing_on_a_failure(tmp_path, monkeypatch):
    import cv2

    from barkgen.io import owned_files

    photo = tmp_path / "bark.png"
    cv2.imwrite(str(photo), bark_exemplar("fir_scaly_01", 128)[..., ::-1])
    args = ["generate", str(photo), "--size", f"{SIZE[1]}x{SIZE[0]}", "--tile", "--material", "--seed", "1"]
    done = run(*args, "-o", str(tmp_path / "out"), "--windowed", "yes")
    assert done.returncode == 0, done.stderr
    written = sorted(p.name for p in (tmp_path / "out").iterdir())
    assert "bark_seed1_1152x160_Color.png" in written and "illumination.png" in written
    assert sorted({*owned_files(tmp_path / "out", "report.json"), "report.json"}) == written

    def full_disk(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr("barkgen.pipeline.encode_generate", full_disk)  # (the set's maps staged by then)
    failed = run_here(*args, "-o", str(tmp_path / "failed"), "--windowed", "yes", "--no-cache")
    assert failed.returncode != 0 and "No space left" in failed.stderr, failed.stderr
    assert not (tmp_path / "failed").exists()  # no map, no temporary, no folder


def test_a_windowed_runs_memory_is_a_windows_and_a_few_bytes_a_pixel(monkeypatch):
    """A 16384² tileable set made window by window is estimated as one window's solve and set
    plus what the run holds whole (72 B a pixel, measured at 4096² and 8192² with a margin), not
    as a whole solve of the output (66 GiB, which refused it on a 24 GiB machine): it is taken
    with 22 GiB free, refused with 16 GiB, and a flow field or height edits (made whole) are
    estimated whole."""
    import barkgen._shared.memory as memory
    from barkgen.errors import MemoryBudgetError
    from barkgen.pipeline.rules import WINDOWED_BYTES_PER_PIXEL, check_generate_memory

    photo = np.zeros((1024, 1024, 3), np.uint8)
    options = GenerateOptions(size=16384, tile=True, material=True)  # auto: windowed above 4096²
    monkeypatch.setattr(memory, "available_memory", lambda: 22 * 2**30)
    need = check_generate_memory(photo, options)
    assert WINDOWED_BYTES_PER_PIXEL * 16384**2 < need < 21 * 2**30
    for whole in ({"along": True}, {"edits": True}):
        with pytest.raises(MemoryBudgetError, match="more than the memory free"):
            check_generate_memory(photo, options, **whole)
    monkeypatch.setattr(memory, "available_memory", lambda: 16 * 2**30)
    with pytest.raises(MemoryBudgetError, match="16384x16384"):
        check_generate_memory(photo, options)
    # at 4096², yes costs less than no
    small = GenerateOptions(size=4096, tile=True, material=True, windowed="yes")
    monkeypatch.setattr(memory, "available_memory", lambda: 22 * 2**30)
    assert check_generate_memory(photo, small) < check_generate_memory(
        photo, GenerateOptions(**{**vars(small), "windowed": "no"})
    )
