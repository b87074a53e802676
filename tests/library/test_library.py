"""The exemplar library: SQLite schema and migrations, content-addressed files, the sample on
first use, analyses and results, removal, and its command line."""

from __future__ import annotations

import json
import sqlite3

import numpy as np
import pytest

from barkgen.cli import main
from barkgen.errors import ImageReadError, ImageTooLargeError, InvalidInputError
from barkgen.io import encode_png
from barkgen.library import SCHEMA_VERSION, Library, LibraryError, NotFoundError
from barkgen.library.store import content_hash


def _png(value: int = 90, size: int = 40) -> bytes:
    rng = np.random.default_rng(value)
    return encode_png(rng.integers(0, 255, (size, size, 3), dtype=np.uint8))


def run(argv, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    out, err = capsys.readouterr()
    return exit_info.value.code, out, err


def test_schema_sample_and_exemplars(tmp_path):
    lib = Library(tmp_path / "lib")
    with sqlite3.connect(lib.db_path) as conn:
        assert conn.execute("PRAGMA user_version").fetchone()[0] == SCHEMA_VERSION
        tables = {r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
    assert {"exemplars", "analyses", "results", "result_files", "settings"} <= tables
    # the bundled sample is there from the first use, and only once
    (sample,) = lib.exemplars()
    assert sample.species == "pine" and sample.licence == "MIT" and (sample.width, sample.height) == (1024, 1024)
    assert lib.store.get(sample.image_hash)[:3] == b"\xff\xd8\xff"
    data = _png()
    oak = lib.add_exemplar(data, "oak", species="oak", bark_type="furrowed", licence="CC0")
    assert oak.image_hash == content_hash(data) and lib.store.path(oak.image_hash).read_bytes() == data
    assert lib.add_exemplar(data, "oak again").id == oak.id  # same bytes, same exemplar
    assert [e.name for e in Library(lib.path).exemplars()] == [sample.name, "oak"]
    assert lib.photo(oak.id).shape == (40, 40, 3)
    # removing the sample is the user's choice: it does not come back
    lib.remove_exemplar(sample.id)
    assert [e.name for e in Library(lib.path).exemplars()] == ["oak"]
    assert not lib.store.exists(sample.image_hash)


def test_bad_input_and_newer_schema(tmp_path):
    lib = Library(tmp_path / "lib", add_sample=False)
    with pytest.raises(ImageReadError):
        lib.add_exemplar(b"not an image", "x")
    with pytest.raises(ImageTooLargeError):
        lib.add_exemplar(_png(size=100), "x", max_pixels=5000)
    with pytest.raises(InvalidInputError):
        lib.add_exemplar(_png(), "  ")
    assert lib.exemplars() == [] and lib.store.digests() == set()
    with pytest.raises(NotFoundError):
        lib.exemplar(7)
    with pytest.raises(NotFoundError):
        lib.result(7)
    with sqlite3.connect(lib.db_path) as conn:
        conn.execute(f"PRAGMA user_version = {SCHEMA_VERSION + 1}")
    with pytest.raises(LibraryError, match="newer barkgen"):
        Library(lib.path)
    (tmp_path / "file").write_text("x")
    with pytest.raises(LibraryError, match="folder"):
        Library(tmp_path / "file")
    (tmp_path / "junk").mkdir()
    (tmp_path / "junk" / "library.sqlite").write_bytes(b"this is not sqlite" * 100)
    with pytest.raises(LibraryError, match="not a barkgen library"):
        Library(tmp_path / "junk")


def test_analyses_results_and_removal(tmp_path):
    lib = Library(tmp_path / "lib", add_sample=False)
    a = lib.add_exemplar(_png(1), "a")
    b = lib.add_exemplar(_png(2), "b")
    assert lib.analysis(a.id, "labels_in", {"k": 3}) is None
    lib.put_analysis(a.id, "labels_in", {"k": 3, "method": "color"}, b"labels-k3")
    assert lib.analysis(a.id, "labels_in", {"method": "color", "k": 3}) == b"labels-k3"  # key order free
    assert lib.analysis(a.id, "labels_in", {"method": "color", "k": 4}) is None
    shared = b"the same bytes in two results"
    r1 = lib.add_result(
        a.id, {"size": [64, 64], "seed": 1}, 1, {"texture.png": b"t1", "x.json": shared}, {"total": 1.5}
    )
    r2 = lib.add_result(
        a.id, {"size": [64, 64], "seed": 2}, 2, {"texture.png": b"t2", "x.json": shared}, parent_id=r1.id
    )
    r3 = lib.add_result(b.id, {"seed": 3}, 3, {"texture.png": b"t3"})
    assert [r.id for r in lib.results()] == [r3.id, r2.id, r1.id]
    assert [r.id for r in lib.results(a.id)] == [r2.id, r1.id]
    assert lib.result(r2.id).parent_id == r1.id and lib.result(r1.id).timings == {"total": 1.5}
    assert lib.result_file(r1.id, "texture.png") == b"t1"
    with pytest.raises(NotFoundError):
        lib.result_file(r1.id, "../library.sqlite")
    # a file two results share stays until neither needs it
    lib.remove_result(r1.id)
    assert lib.result(r2.id).parent_id is None
    assert lib.store.exists(content_hash(shared)) and not lib.store.exists(content_hash(b"t1"))
    lib.remove_exemplar(a.id)
    assert [r.id for r in lib.results()] == [r3.id]
    assert not lib.store.exists(content_hash(shared)) and not lib.store.exists(content_hash(b"labels-k3"))
    assert lib.store.digests() == {b.image_hash, content_hash(b"t3")}


def test_library_add_derives_one_clean_line_from_any_file_name(tmp_path, capsys, monkeypatch):
    """A file name with a newline or bytes that are no UTF-8 gives a clean entry name and
    source (issue 67: it was refused as "not one line of printable text")."""
    import os

    monkeypatch.setenv("BARKGEN_LIBRARY", str(tmp_path / "lib"))
    for raw, name in ((b"old\noak.png", "old oak"), (b"caf\xe9 bark.png", "caf\ufffd bark")):
        photo = tmp_path / os.fsdecode(raw)
        photo.write_bytes(_png(len(raw)))
        code, out, err = run(["library", "add", str(photo)], capsys)
        assert code in (0, None), err
        assert out.split("\t")[1].strip() == name
        shown = json.loads(run(["library", "show", out.split("\t")[0]], capsys)[1])
        assert "\n" not in shown["source"] and shown["name"] == name


def test_library_cli(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("BARKGEN_LIBRARY", str(tmp_path / "envlib"))
    photo = tmp_path / "old oak.png"
    photo.write_bytes(_png(5))
    code, out, err = run(["library", "add", str(photo), "--species", "oak", "--licence", "CC0"], capsys)
    assert code in (0, None), err
    exemplar_id = int(out.split("\t")[0])
    assert "old oak" in out
    code, out, _ = run(["library", "add", str(photo)], capsys)
    assert "already in the library" in out
    code, out, err = run(["library", "list"], capsys)
    assert "Sample pine bark" in out and "old oak" in out and "oak" in out and "envlib" in err
    code, out, _ = run(["library", "show", str(exemplar_id)], capsys)
    shown = json.loads(out)
    assert shown["species"] == "oak" and shown["licence"] == "CC0" and shown["results"] == []
    # --library wins over the environment
    code, out, _ = run(["library", "list", "--library", str(tmp_path / "other")], capsys)
    assert "old oak" not in out
    code, out, _ = run(["library", "rm", str(exemplar_id)], capsys)
    assert "removed" in out
    # bad input: one line, exit 2, no traceback
    for argv in (
        ["library", "show", "99"],
        ["library", "rm", "99"],
        ["library", "add", str(tmp_path / "missing.png")],
        ["library", "list", "--library", str(photo)],
    ):
        code, out, err = run(argv, capsys)
        assert code == 2 and err.startswith("barkgen: error:") and err.count("\n") == 1, (argv, err)
    (tmp_path / "text.jpg").write_text("not a photo")
    code, _, err = run(["library", "add", str(tmp_path / "text.jpg")], capsys)
    assert code == 2 and "not an image" in err


def test_serve_refuses_a_taken_port(tmp_path, capsys):
    import socket

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        code, _, err = run(["serve", "--port", str(port), "--library", str(tmp_path / "lib")], capsys)
    assert code == 2 and "cannot listen" in err and err.count("\n") == 1
    code, _, err = run(["serve", "--port", "0", "--library", str(tmp_path / "lib")], capsys)
    assert code == 2 and "--port" in err


def test_batch_spec_takes_library_ids(tmp_path):
    from barkgen.batch import parse_spec

    lib = Library(tmp_path / "lib")
    oak = lib.add_exemplar(_png(8), "Old oak / north side", species="oak")
    spec = parse_spec(
        {
            "size": "64x64",
            "exemplars": [{"library": oak.id, "count": 2}, {"library": 1, "name": "sample", "seeds": [5]}],
        },
        tmp_path,
        library=lib,
    )
    first, second = spec.exemplars
    assert first.name == "Old-oak-north-side" and first.seeds == (0, 1)
    assert first.path.read_bytes() == lib.photo_bytes(oak.id)
    assert first.source_name == f"library:{oak.id} (Old oak / north side)"
    assert second.name == "sample" and second.path == lib.store.path(lib.exemplar(1).image_hash)
    for entry, message in (
        ({"library": 99, "count": 1}, "no exemplar 99"),
        ({"library": "oak", "count": 1}, "exemplar id"),
        ({"library": oak.id, "path": "x.jpg", "count": 1}, "not both"),
    ):
        with pytest.raises(InvalidInputError, match=message):
            parse_spec({"exemplars": [entry]}, tmp_path, library=lib.path)


def test_a_read_only_library_is_listed_and_refuses_changes(tmp_path, capsys, monkeypatch):
    """A library on a read-only disk or folder (a shared asset server, a DVD) lists and shows
    as it stands, and a change is one clear line (`list` said "not a barkgen library")."""
    import os
    import stat

    lib = Library(tmp_path / "lib")
    oak = lib.add_exemplar(_png(), "oak", species="oak")
    # an older barkgen's library (schema 1, no job queue): read as it stands, not upgraded
    with sqlite3.connect(lib.db_path) as conn:
        conn.execute("DROP TABLE jobs")
        conn.execute("PRAGMA user_version = 1")
    folders = [tmp_path / "lib", *(p for p in (tmp_path / "lib").rglob("*") if p.is_dir())]
    files = [p for p in (tmp_path / "lib").rglob("*") if p.is_file()]
    for path in files + folders:
        path.chmod(path.stat().st_mode & ~(stat.S_IWUSR | stat.S_IWGRP | stat.S_IWOTH))
    real_access = os.access
    if os.geteuid() == 0:  # root writes anywhere: let the library see what another user sees
        monkeypatch.setattr(
            os,
            "access",
            lambda path, mode, **kw: (
                False
                if mode & os.W_OK and str(path).startswith(str(tmp_path / "lib"))
                else real_access(path, mode, **kw)
            ),
        )
    try:
        before = {p: p.read_bytes() for p in files}
        code, out, err = run(["library", "list", "--library", str(tmp_path / "lib")], capsys)
        assert code == 0 and "oak" in out and "Sample pine bark" in out, err
        code, out, err = run(["library", "show", str(oak.id), "--library", str(tmp_path / "lib")], capsys)
        assert code == 0 and json.loads(out)["species"] == "oak"
        code, out, err = run(["library", "rm", str(oak.id), "--library", str(tmp_path / "lib")], capsys)
        assert code == 2 and "read-only" in err and len(err.strip().splitlines()) == 1, err
        readonly = Library(tmp_path / "lib")
        assert readonly.read_only and [e.name for e in readonly.exemplars()] == ["Sample pine bark", "oak"]
        with pytest.raises(LibraryError, match="read-only"):
            readonly.add_exemplar(_png(7), "pine")
        assert {p: p.read_bytes() for p in files} == before  # nothing was written
        assert sorted((tmp_path / "lib").iterdir()) == sorted(
            p for p in folders + files if p.parent == tmp_path / "lib"
        )
    finally:
        for path in files + folders:
            path.chmod(path.stat().st_mode | stat.S_IWUSR)


def test_a_scanned_set_is_kept_with_its_maps(tmp_path):
    library = Library(tmp_path / "lib", add_sample=False)
    colour = encode_png(np.random.default_rng(0).integers(0, 255, (32, 32, 3), dtype=np.uint8))
    rough = encode_png(np.full((32, 32, 1), 200, np.uint8))
    ao = encode_png(np.full((32, 32, 1), 100, np.uint8))
    files = {"Bark7_Color.png": colour, "Bark7_Roughness.png": rough, "Bark7.usda": b"#usda"}
    exemplar = library.add_scanned_set(files, licence="CC0")
    assert exemplar.name == "Bark7" and exemplar.maps == ("roughness",) and exemplar.licence == "CC0"
    assert library.set_files(exemplar.id) == {"Bark7_Color.png": colour, "Bark7_Roughness.png": rough}
    assert library.photo_bytes(exemplar.id) == colour
    # the same set again: its entry; the same colour with other maps: a set of its own, the first
    # one kept as it was
    assert library.add_scanned_set(files).id == exemplar.id
    again = library.add_scanned_set({"Bark7_Color.png": colour, "Bark7_AO.png": ao})
    assert again.id != exemplar.id and again.maps == ("ao",) and library.exemplar(exemplar.id).maps == ("roughness",)
    assert library.photo_bytes(again.id) == colour and library.set_files(exemplar.id)["Bark7_Roughness.png"] == rough
    # a set is never taken for a photo of its colour: the photo is an entry of its own, and the
    # set zipped after the photo is one too
    assert library.find_exemplar(colour) is None
    photo = library.add_exemplar(colour, "the photo")
    assert photo.id not in (exemplar.id, again.id) and photo.maps == () and library.set_files(photo.id) == {}
    assert library.find_exemplar(colour).id == photo.id and library.photo_bytes(photo.id) == colour
    # removing a set removes the maps' files nothing else uses (the colour stays for the others)
    library.remove_exemplar(exemplar.id)
    assert not library.store.exists(content_hash(rough)) and library.store.exists(content_hash(colour))
    library.remove_exemplar(again.id)
    library.remove_exemplar(photo.id)
    assert not library.store.exists(content_hash(ao)) and not library.store.exists(content_hash(colour))
    # maps of another size than the colour's are taken (resampled when a run reads them)
    smaller = library.add_scanned_set({"B_Color.png": colour, "B_AO.png": encode_png(np.zeros((16, 16, 1), np.uint8))})
    assert smaller.maps == ("ao",) and (smaller.width, smaller.height) == (32, 32)


def test_library_add_takes_a_sets_folder_or_zip(tmp_path, capsys):
    import zipfile

    folder = tmp_path / "Bark3_1K"
    folder.mkdir()
    rng = np.random.default_rng(1)
    (folder / "Bark3_1K_Color.png").write_bytes(encode_png(rng.integers(0, 255, (32, 32, 3), dtype=np.uint8)))
    (folder / "Bark3_1K_AmbientOcclusion.png").write_bytes(encode_png(np.full((32, 32, 1), 9, np.uint8)))
    (folder / "Bark3.usda").write_text("#usda 1.0")
    lib = str(tmp_path / "lib")
    code, out, err = run(["library", "add", str(folder), "--library", lib], capsys)
    assert code in (0, None) and "Bark3\t(a scanned set: colour + ao)" in out, err
    with zipfile.ZipFile(tmp_path / "other.zip", "w") as archive:
        archive.writestr("Other_Color.png", encode_png(np.zeros((32, 32, 3), np.uint8)))
        archive.writestr("Other_Sheen.png", encode_png(np.zeros((32, 32, 3), np.uint8)))
    code, out, err = run(["library", "add", str(tmp_path / "other.zip"), "--library", lib], capsys)
    # a file it cannot place: one line naming it, the set made from the others
    assert code in (0, None) and "\tOther\t" in out, err
    assert "other.zip/Other_Sheen.png: left out" in err and len(err.strip().splitlines()) == 1
