"""Nothing lost, nothing runaway (the hostile and clumsy user's cases): an output that is an
input is refused, a folder never holds two runs' sets, a killed writer's temporaries are
cleared by the next write, SIGTERM ends a run as Ctrl-C does, a thin strip is sized for its
shape, and parse errors, huge ids and stray files get one line."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import run, run_here

from barkgen.io import read_image, write_files_atomic, write_png


@pytest.fixture
def decoded(monkeypatch) -> list[str]:
    """The names of the decoders called while the test runs (Pillow's pixel load, OpenCV's and
    tifffile's readers, barkgen's :func:`~barkgen.io.decode_image`): a refusal made from an
    image's header leaves it empty (clear it after the test's own reads)."""
    import cv2
    import tifffile
    from PIL import Image, ImageFile, WebPImagePlugin

    import barkgen.io.images

    calls: list[str] = []

    def recording(owner, name: str) -> None:
        real = getattr(owner, name)

        def record(*args, **kwargs):
            calls.append(f"{getattr(owner, '__name__', owner)}.{name}")
            return real(*args, **kwargs)

        monkeypatch.setattr(owner, name, record)

    for owner, name in [
        (ImageFile.ImageFile, "load"),
        (Image.Image, "load"),
        (WebPImagePlugin.WebPImageFile, "load"),
        (cv2, "imdecode"),
        (cv2, "imread"),
        (tifffile, "imread"),
        (tifffile.TiffPage, "asarray"),
        (barkgen.io.images, "decode_image"),
    ]:
        recording(owner, name)
    return calls


def peak_bytes(call) -> tuple[object, int]:
    """``(call(), the peak of Python's allocations while it ran)`` (numpy's arrays and every
    file read into bytes included; run the call once before, so imports are not counted)."""
    import tracemalloc

    tracemalloc.start()
    try:
        return call(), tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


@pytest.fixture(scope="module")
def photo(tmp_path_factory, synthetic_exemplar) -> Path:
    p = tmp_path_factory.mktemp("photo") / "p.png"
    write_png(p, synthetic_exemplar)
    return p


def _one_line(r: subprocess.CompletedProcess, *words: str) -> None:
    assert r.returncode == 2, (r.returncode, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("barkgen: error: "), r.stderr
    assert "Traceback" not in r.stderr and "Usage:" not in r.stderr
    for word in words:
        assert word in lines[0], (word, lines[0])


def test_an_output_that_is_an_input_is_refused_and_the_input_kept(tmp_path, photo, decoded):
    src = tmp_path / "p.png"
    src.write_bytes(photo.read_bytes())
    before = src.read_bytes()
    _one_line(run("synth", str(src), "-o", str(src), "--size", "32x32", "-q"), "also an input")
    _one_line(run("labels", str(src), "-o", str(src), "-q"), "also an input")
    # the same file by another name (a symbolic link) is the same file
    (tmp_path / "link.png").symlink_to(src)
    _one_line(run("synth", str(src), "-o", str(tmp_path / "link.png"), "--size", "32x32", "-q"))
    # generate OUT/texture.png -o OUT: refused before any work, not after it (the photo is not
    # even decoded; the time it takes is bench_abuse's)
    out = tmp_path / "out"
    out.mkdir()
    (out / "texture.png").write_bytes(before)
    _one_line(run_here("generate", str(out / "texture.png"), "-o", str(out), "--size", "512x512", "-q"), "texture.png")
    assert decoded == []
    assert src.read_bytes() == before and (out / "texture.png").read_bytes() == before
    assert sorted(p.name for p in out.iterdir()) == ["texture.png"]
    # preview into its own set's files: refused; beside them: fine
    sets = tmp_path / "set"
    assert run("generate", str(src), "-o", str(sets), "--size", "32x32", "--material", "-q").returncode == 0
    colour_map = sets / "p_seed0_32x32_Color.png"  # the photo's name, the seed, the size
    colour = colour_map.read_bytes()
    _one_line(run("preview", str(sets), "-o", str(colour_map)), colour_map.name)
    assert colour_map.read_bytes() == colour
    assert run("preview", str(sets), "-o", str(sets / "trunk.png")).returncode == 0


def test_a_rerun_replaces_the_folders_set_as_a_whole(tmp_path, photo):
    out = tmp_path / "out"
    assert (
        run("generate", str(photo), "-o", str(out), "--size", "48x48", "--seed", "5", "--material", "-q").returncode
        == 0
    )
    assert (out / "p_seed5_48x48_Color.png").is_file()
    (out / "notes.txt").write_text("mine")  # not a run's file: stays
    assert run("generate", str(photo), "-o", str(out), "--size", "32x32", "--seed", "9", "-q").returncode == 0
    names = sorted(p.name for p in out.iterdir())
    assert names == [
        "labels_in.png",
        "labels_out.png",
        "notes.txt",
        "preview.png",
        "reference.png",
        "report.json",
        "texture.png",
    ], names
    assert read_image(out / "texture.png").shape[:2] == (32, 32)
    # the stale maps are gone, so preview says there is no set instead of using them
    _one_line(run("preview", str(out), "-o", str(tmp_path / "t.png")), "no material set")


def _dead_pid() -> int:
    pid = 4_000_000
    while True:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return pid
        except OSError:
            pass
        pid -= 1


def test_a_run_removes_only_what_it_can_prove_a_run_wrote(tmp_path, photo):
    """Another program's report.json listing the user's files, or a run's file the user has
    edited since: neither is removed by the next run. What the last run provably wrote (its
    record's SHA-256 still matches) and the new run does not write, is."""
    import json

    out = tmp_path / "out"
    out.mkdir()
    (out / "holiday.jpg").write_bytes(b"\xff\xd8 a photo")
    (out / "notes.txt").write_text("mine")
    (out / "report.json").write_text(json.dumps({"files": ["holiday.jpg", "notes.txt"]}))
    assert run("generate", str(photo), "-o", str(out), "--size", "32x32", "--material", "-q").returncode == 0
    assert (out / "holiday.jpg").is_file() and (out / "notes.txt").read_text() == "mine"
    # a forged record naming the user's file with a wrong hash proves nothing either
    record = json.loads((out / "report.json").read_text())
    assert record["file_sha256"]["texture.png"] and "holiday.jpg" not in record["files"]
    (out / "p_seed0_32x32_Roughness.png").write_bytes(b"edited by the user")
    assert run("generate", str(photo), "-o", str(out), "--size", "32x32", "-q").returncode == 0
    names = {p.name for p in out.iterdir()}
    assert {"holiday.jpg", "notes.txt", "p_seed0_32x32_Roughness.png"} <= names  # the user's, kept
    assert not {"p_seed0_32x32_Color.png", "p_seed0_32x32.json"} & names  # the last run's, removed


def test_a_folder_is_replaced_whole_only_when_a_run_wrote_all_of_it(tmp_path, photo):
    """write_folder_atomic (batch's variants) replaces a folder only if it is missing, empty,
    or holds nothing but a run barkgen wrote; else one line, and nothing is touched."""
    from barkgen.errors import InvalidInputError
    from barkgen.io import write_folder_atomic
    from barkgen.pipeline import GenerateOptions, encode_generate, generate

    image = read_image(photo)
    files = encode_generate(image, generate(image, GenerateOptions(size=(32, 32))), "p.png")
    target = tmp_path / "bark" / "0"
    write_folder_atomic(target, files)
    write_folder_atomic(target, files)  # a run's folder: replaced
    (target / "notes.txt").write_text("mine")
    with pytest.raises(InvalidInputError, match="notes.txt"):
        write_folder_atomic(target, files)
    assert (target / "notes.txt").read_text() == "mine" and (target / "texture.png").is_file()
    users = tmp_path / "photos"
    users.mkdir()
    (users / "p.jpg").write_bytes(b"a photo")
    with pytest.raises(InvalidInputError, match="p.jpg"):
        write_folder_atomic(users, files)
    assert sorted(p.name for p in users.iterdir()) == ["p.jpg"]
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".barkgen")]


@pytest.mark.parametrize(
    "case",
    [
        "extra is OUT_NAME",
        "photo is OUT_NAME",
        "tbn extra",
        "debug dir",
        "textons",
        "save-levels and resume",
        "material colour",
        "material edits",
    ],
)
def test_every_file_a_command_will_write_is_checked_before_any_work(tmp_path, photo, case, decoded):
    """The derived names (OUT_NAME.png of an --extra, the debug pictures, the texton masks, the
    pyramid levels, a material set's maps) are outputs like -o: none may be an input. Refused in
    one line before any work (no image decoded), and nothing is written or changed."""
    d = tmp_path / "d"
    d.mkdir()
    data = photo.read_bytes()
    labels = tmp_path / "labels.png"
    write_png(labels, (read_image(photo)[..., 0] > 128).astype(np.uint8) * 255)
    args = {
        "extra is OUT_NAME": (
            "synth",
            str(photo),
            "-o",
            str(d / "o.png"),
            "--size",
            "32x32",
            "--extra",
            f"height={d / 'o_height.png'}",
        ),
        "photo is OUT_NAME": (
            "synth",
            str(d / "q_height.png"),
            "-o",
            str(d / "q.png"),
            "--size",
            "32x32",
            "--extra",
            f"height={photo}",
        ),
        "tbn extra": (
            "tbn",
            str(photo),
            "--labels",
            str(labels),
            "--target",
            str(labels),
            "-o",
            str(d / "t.png"),
            "--extra",
            f"height={d / 't_height.png'}",
        ),
        "debug dir": (
            "tbn",
            str(d / "feature_distance.png"),
            "--labels",
            str(labels),
            "--target",
            str(labels),
            "-o",
            str(tmp_path / "t.png"),
            "--debug-dir",
            str(d),
        ),
        "textons": ("textons", str(d / "textons.png"), "-o", str(d), "--textons", "4"),
        "save-levels and resume": (
            "generate",
            str(photo),
            "-o",
            str(tmp_path / "out"),
            "--size",
            "64x64",
            "--resume",
            str(d / "level_1.png"),
            "--save-levels",
            str(d),
        ),
        "material colour": ("material", str(d / "bark_40x48_Color.png"), "--name", "bark", "-o", str(d)),
        "material edits": (
            "material",
            str(photo),
            "--edits",
            str(d / "bark_40x48.json"),
            "--name",
            "bark",
            "-o",
            str(d),
        ),
    }[case]
    named = {
        "extra is OUT_NAME": "o_height.png",
        "photo is OUT_NAME": "q_height.png",
        "tbn extra": "t_height.png",
        "debug dir": "feature_distance.png",
        "textons": "textons.png",
        "save-levels and resume": "level_1.png",
        "material colour": "bark_40x48_Color.png",  # (--name's set of the 40x48 photo)
        "material edits": "bark_40x48.json",
    }[case]
    if named == "level_1.png":
        write_png(d / named, (read_image(photo)[::4, ::4, 0] > 128).astype(np.uint8) * 255)
    elif named == "bark_40x48.json":
        (d / named).write_text('{"version": 1, "edits": []}')
    else:
        (d / named).write_bytes(data)
    before = {p.name: p.read_bytes() for p in d.iterdir()}
    decoded.clear()  # (the set-up's own reads)
    _one_line(run_here(*args, "-q"), named)
    assert decoded == []  # refused before any work (its time: benchmarks/bench_abuse.py)
    assert {p.name: p.read_bytes() for p in d.iterdir()} == before
    assert not (tmp_path / "out").exists() and not (tmp_path / "t.png").exists()


def test_outputs_in_several_folders_are_written_together_or_not_at_all(tmp_path):
    """A failure on the last output (here its folder cannot be made; a full disk alike: on a
    300 KB tmpfs, labels --preview, textons and generate --save-levels left nothing) leaves
    none of the others, no temporary, and no folder made for them."""
    from barkgen.cli._common import write_outputs

    (tmp_path / "blocker").write_text("a file where a folder should be")
    with pytest.raises(OSError):
        write_outputs({tmp_path / "a" / "x.png": b"x", tmp_path / "blocker" / "y.png": b"y"})
    assert not (tmp_path / "a").exists()  # nor the folder made for them


def test_the_next_write_clears_a_killed_writers_temporaries_and_nothing_else(tmp_path):
    """Only barkgen's own temporaries (``.barkgen.PID.XXXX.tmp``) whose writer is gone are
    removed: a running writer's stay, and so does every file of the user's, however much it
    looks like one (a dead process id in its name, an hour old, an older barkgen's naming)."""
    folder = tmp_path / "out"
    folder.mkdir()
    dead = folder / f".barkgen.{_dead_pid()}.k3j2h1g0.tmp"
    live = folder / f".barkgen.{os.getpid()}.zz99yy88.tmp"  # a running writer's: kept
    users = [
        folder / ".thesis.32000.bak.tmp",
        folder / ".backup.tmp",
        folder / f".texture.png.{_dead_pid()}.k3j2h1g0.tmp",
        folder / ".preview.png.abc123xy.tmp",
    ]
    for path in [dead, live, *users]:
        path.write_bytes(b"x" * 1000)
        os.utime(path, (time.time() - 3600, time.time() - 3600))
    write_files_atomic(folder, {"a.txt": b"a"})
    left = sorted(p.name for p in folder.iterdir())
    assert left == sorted([live.name, "a.txt"] + [p.name for p in users]), left


def test_a_temporarys_name_is_short_whatever_the_targets(tmp_path):
    """A target whose name is as long as the file system allows still gets written: the
    temporary beside it does not carry the target's name."""
    name = "n" * 240 + ".png"
    write_files_atomic(tmp_path, {name: b"data"})
    assert (tmp_path / name).read_bytes() == b"data"


def test_sigterm_ends_a_run_like_ctrl_c(tmp_path, photo):
    out = tmp_path / "out"
    proc = subprocess.Popen(
        [sys.executable, "-m", "barkgen", "generate", str(photo), "-o", str(out), "--size", "2048x2048", "-q"],
        stderr=subprocess.PIPE,
        text=True,
    )
    # started, imported, working (the run takes far longer): 3 s of its own CPU, however busy
    # the machine, not 4 s of the clock (where /proc is missing, the clock)
    stat = Path(f"/proc/{proc.pid}/stat")
    if stat.exists():
        ticks = os.sysconf("SC_CLK_TCK")
        while proc.poll() is None and sum(map(int, stat.read_text().rpartition(")")[2].split()[11:13])) < 3 * ticks:
            time.sleep(0.1)
    else:
        time.sleep(4)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, (proc.returncode, err)
    assert err.strip() == "barkgen: error: interrupted"
    assert not out.exists() or not any(out.iterdir())


def test_a_thin_strip_is_sized_for_its_shape(tmp_path, photo):
    out = tmp_path / "strip"
    r = run("generate", str(photo), "-o", str(out), "--size", "1x20000", "-q")
    assert r.returncode == 0, r.stderr
    assert read_image(out / "texture.png").shape[:2] == (20000, 1)
    sheet = read_image(out / "preview.png")
    assert sheet.shape[0] < 4 * 320 + 100  # was 320 px wide per tile: 6.4 million rows


def test_contact_sheet_fits_every_tile_in_its_box():
    from barkgen.labels import contact_sheet
    from barkgen.labels.preview import MAX_TILE_ASPECT

    strip = np.zeros((100_000, 1), np.uint8)
    sheet = contact_sheet([strip, np.zeros((10, 10), np.uint8)], columns=2, tile_size=50)
    assert sheet.shape[0] <= MAX_TILE_ASPECT * 50 + 22 + 3
    # an ordinary tile still spans the whole width
    assert contact_sheet([np.full((10, 20), 7, np.uint8)], columns=1, tile_size=40)[3:23, 3:43].max() == 7


def test_parse_errors_sizes_and_bands_are_one_line(tmp_path, photo):
    _one_line(run("synth", str(photo), "-o", str(tmp_path / "s.png"), "--seed", "-1"), "--seed")
    _one_line(run("synth", str(photo), "-o", str(tmp_path / "s.png"), "--threads", "0"), "--threads")
    _one_line(run("library", "rm", "abc"), "ID")
    _one_line(run("synth", str(photo), "--no-such-flag"), "--no-such-flag")
    _one_line(
        run("generate", str(photo), "-o", str(tmp_path / "m"), "--size", "64x64", "--max-memory", "10M"), "10 MiB"
    )
    _one_line(run("labels", str(photo), "-o", str(tmp_path / "e.png"), "--edges", "--edge-width", "100000"), "edge")
    assert not (tmp_path / "e.png").exists()
    assert run("--version").returncode == 0


def test_huge_ids_and_stray_files_in_the_library(tmp_path):
    env = {**os.environ, "BARKGEN_LIBRARY": str(tmp_path / "lib")}
    cmd = [sys.executable, "-m", "barkgen", "library"]
    r = subprocess.run(cmd + ["show", "99999999999999999999"], capture_output=True, text=True, env=env)
    _one_line(r, "no exemplar")
    # a desktop's stray file among the stored objects is not an object
    objects = tmp_path / "lib" / "objects"
    sub = next(p for p in objects.iterdir() if p.is_dir())
    (sub / ".DS_Store").write_bytes(b"\0")
    (objects / "Thumbs.db").write_bytes(b"\0")
    r = subprocess.run(cmd + ["rm", "1"], capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr


def test_an_unwritable_output_folder_is_refused_before_any_work(tmp_path, monkeypatch):
    from barkgen.cli._common import guard_paths
    from barkgen.errors import InvalidInputError

    target = tmp_path / "locked"
    target.mkdir()
    monkeypatch.setattr(os, "access", lambda path, mode: Path(path) != target)
    with pytest.raises(InvalidInputError, match="cannot write into"):
        guard_paths({"output_dir": target / "new" / "deeper"})
    with pytest.raises(InvalidInputError, match="cannot write into"):
        guard_paths({"output": target / "x.png"})
    guard_paths({"output": tmp_path / "x.png"})()  # a writable folder: fine (and forgotten)
    # the bits say yes, the file system says no (root under /proc): asked before any work too
    monkeypatch.undo()
    with pytest.raises(InvalidInputError, match="cannot write into '/proc'"):
        guard_paths({"output_dir": Path("/proc/barkgen-out/set")})
    assert not list(tmp_path.glob(".barkgen-probe*"))


def test_records_of_a_non_utf8_path_are_valid_json(tmp_path, photo):
    import json

    folder = Path(os.fsdecode(bytes(tmp_path) + b"/caf\xe9"))  # Latin-1 bytes in the name
    folder.mkdir()
    src = folder / "p.png"
    src.write_bytes(photo.read_bytes())
    out = tmp_path / "out"
    assert run("generate", str(src), "-o", str(out), "--size", "32x32", "--material", "-q").returncode == 0
    for record in ("report.json", "p_seed0_32x32.json"):
        text = (out / record).read_bytes().decode("utf-8")  # strict UTF-8
        data = json.loads(text)
        assert "\\ud" not in text and all(not 0xD800 <= ord(c) <= 0xDFFF for c in json.dumps(data, ensure_ascii=False))


def test_generate_takes_the_colour_label_maps_tbn_takes(tmp_path, photo):
    h, w = read_image(photo).shape[:2]
    colours = np.zeros((h, w, 3), np.uint8)
    colours[: h // 2] = (200, 30, 30)
    colours[h // 2 :] = (20, 90, 200)
    write_png(tmp_path / "labels.png", colours)
    out = tmp_path / "out"
    r = run("generate", str(photo), "--labels", str(tmp_path / "labels.png"), "-o", str(out), "--size", "32x32", "-q")
    assert r.returncode == 0, r.stderr
    labels_in = read_image(out / "labels_in.png")[..., 0]
    # two labels, the darker colour first (the red: luma 66 against the blue's 83)
    assert sorted(np.unique(labels_in)) == [0, 255]
    assert labels_in[0, 0] == 0 and labels_in[-1, 0] == 255


def test_an_image_declaring_huge_pixels_is_refused_from_its_header(tmp_path, photo, decoded):
    """A 120 KB PNG declaring 121 megapixels (it ran 11 minutes) is refused from its header:
    no decoder is called and no more than a few MB are allocated (the image is 121 MB)."""
    from PIL import Image

    big = tmp_path / "big.png"
    Image.new("L", (11000, 11000)).save(big, optimize=True)  # 121 megapixels in ~120 KB
    assert big.stat().st_size < 300_000
    for command in (
        ["labels", str(big), "-o", str(tmp_path / "l.png")],
        ["synth", str(big), "-o", str(tmp_path / "s.png"), "--size", "64x64"],
        ["material", str(big), "-o", str(tmp_path / "m")],
    ):
        run_here(*command)  # (its imports, not counted below)
        decoded.clear()
        result, peak = peak_bytes(lambda command=command: run_here(*command))
        _one_line(result, "121 megapixels", "--max-pixels")
        assert decoded == [], command
        assert peak < 8 * 2**20, (command, peak)  # its time: benchmarks/bench_abuse.py
    read_image(photo)
    assert decoded  # (the recorder sees a decode)
    # the limit is the user's to set
    _one_line(
        run("--max-pixels", "100", "labels", str(photo), "-o", str(tmp_path / "l.png")), "more than the limit of 0.0001"
    )


@pytest.mark.parametrize(
    "case",
    [
        "png named .dat",
        "png with no suffix",
        "device",
        "zeros named .png",
        "huge output",
        "5000-digit size",
        "200,000 edits",
        "nested edits",
    ],
)
def test_every_input_is_bounded_before_it_is_read_and_every_output_before_it_is_made(tmp_path, photo, case, decoded):
    """An image is known by its content, not its name; a reader is bounded in bytes and pixels
    before it decodes; an output is bounded in pixels like an input; one line, and no image
    decoded, no input read whole, nothing big allocated (the 64 MP image is 64 MB, the file of
    zeros 50 MB; how fast: benchmarks/bench_abuse.py)."""
    import json

    import cv2

    big = tmp_path / "big.png"
    cv2.imwrite(str(big), np.zeros((8000, 8000), np.uint8))  # 64 MP, 60 KB
    if case in ("png named .dat", "png with no suffix"):
        target = tmp_path / ("big.dat" if case == "png named .dat" else "big")
        target.write_bytes(big.read_bytes())
        args, word = ("labels", str(target), "-o", str(tmp_path / "l.png")), "megapixels"
    elif case == "device":
        args, word = ("labels", "/dev/zero", "-o", str(tmp_path / "l.png")), "not a regular file"
    elif case == "zeros named .png":
        (tmp_path / "z.png").write_bytes(bytes(50_000_000))
        args, word = ("synth", str(tmp_path / "z.png"), "-o", str(tmp_path / "s.png")), "not an image"
    elif case == "huge output":
        args, word = ("synth", str(photo), "-o", str(tmp_path / "s.png"), "--size", "1x99999999"), "--max-pixels"
    elif case == "5000-digit size":
        args, word = ("synth", str(photo), "-o", str(tmp_path / "s.png"), "--size", "1x" + "9" * 5000), "invalid size"
    else:
        edits = tmp_path / "e.json"
        if case == "200,000 edits":
            edits.write_text(json.dumps({"version": 1, "edits": [{"x": 1, "y": 1, "delta": 0.5}] * 200_000}))
        else:
            edits.write_text("[" * 100_000 + "]" * 100_000)
        args, word = ("material", str(photo), "--edits", str(edits), "-o", str(tmp_path / "m")), str(edits.name)
    run_here(*args, "-q")  # (its imports, not counted below)
    decoded.clear()
    result, peak = peak_bytes(lambda: run_here(*args, "-q"))
    _one_line(result, word)
    assert decoded == []
    assert peak < 4 * 2**20, peak  # (1.2-1.6 MB; the 200,000 edits' file alone is 6.6 MB)
    assert not [p for p in tmp_path.iterdir() if p.name in ("l.png", "s.png", "m")]


def test_a_library_name_is_one_line(tmp_path, photo):
    """A name with a newline broke `library list`'s table: refused, like any control character."""
    r = run("library", "add", str(photo), "--name", "two\nlines", "--library", str(tmp_path / "lib"))
    _one_line(r, "one line")


def test_a_damaged_library_is_one_line(tmp_path, photo):
    """A torn page in library.sqlite made `library list` an internal error (exit 1)."""
    lib = tmp_path / "lib"
    assert run("library", "add", str(photo), "--name", "a", "--library", str(lib)).returncode == 0
    db = lib / "library.sqlite"
    data = bytearray(db.read_bytes())
    data[4096 : 3 * 4096] = b"\x5a" * (2 * 4096)
    db.write_bytes(bytes(data))
    _one_line(run("library", "list", "--library", str(lib)), "damaged")
