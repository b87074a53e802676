"""The photo analysis cache (:mod:`barkgen.pipeline.analysis_cache`): same bytes from a hit,
what its key covers, concurrent writers, a torn file, an upgraded version, eviction of the least
recently used, ``--no-cache`` and ``barkgen cache``."""

from __future__ import annotations

import multiprocessing
import os
import threading
from pathlib import Path

import numpy as np
import pytest
from conftest import run_here

from barkgen.io import write_png
from barkgen.pipeline import (
    AnalysisStore,
    GenerateOptions,
    analysis_cache,
    analyze_photo,
    cached_analysis,
    generate,
    open_store,
)
from barkgen.pipeline.analysis_cache import analysis_digest

OPTIONS = GenerateOptions(size=(96, 96), k=3, tile=True, material=True, seed=1)


@pytest.fixture(scope="module")
def photo() -> np.ndarray:
    from barkgen.data import sample_exemplar_path
    from barkgen.io import read_image

    return np.ascontiguousarray(read_image(sample_exemplar_path())[:96, :96])


@pytest.fixture(scope="module")
def analysis(photo):
    return analyze_photo(photo, OPTIONS)


def _same_result(a, b) -> None:
    assert np.array_equal(a.texture, b.texture)
    assert np.array_equal(a.references, b.references)
    assert np.array_equal(a.labels_out, b.labels_out)
    maps = [(n, v) for n, v in vars(a.material).items() if isinstance(v, np.ndarray)]
    assert len(maps) >= 4
    for name, value in maps:
        assert np.array_equal(value, getattr(b.material, name)), name


def test_a_hit_gives_the_same_bytes_for_another_seed(tmp_path, photo):
    store, hits = AnalysisStore(tmp_path), []
    cached_analysis(photo, OPTIONS, store=store, on_hit=hits.append)
    assert not hits and len(store.entries()) == 1
    other = GenerateOptions(size=(96, 96), k=3, tile=True, material=True, seed=7, threads=1)
    found = cached_analysis(photo, other, store=store, on_hit=hits.append)
    assert len(hits) == 1 and found.options == other
    _same_result(generate(photo, other, analysis=found), generate(photo, other))


def test_the_key_covers_what_the_analysis_depends_on_and_nothing_else(photo):
    from barkgen.branching import Structure

    key = analysis_digest(photo, OPTIONS)
    # the seed and the run's budget play no part
    assert analysis_digest(photo, GenerateOptions(size=(96, 96), k=3, tile=True, material=True, seed=9)) == key
    assert analysis_digest(photo.copy(), OPTIONS) == key
    changed = photo.copy()
    changed[5, 5, 0] ^= 1
    others = {
        analysis_digest(changed, OPTIONS),
        analysis_digest(photo, GenerateOptions(size=(96, 96), k=4, tile=True, material=True)),
        analysis_digest(photo, OPTIONS, extra={"height": photo[..., 0]}),
        analysis_digest(photo, OPTIONS, labels_in=(photo[..., 0] > 128).astype(np.uint8)),
        analysis_digest(photo, OPTIONS, solvers=False),
        analysis_digest(photo.astype(np.uint16), OPTIONS),
        analysis_digest(photo, OPTIONS, cracks=Structure(2.0, (96, 96))),
        analysis_digest(photo, OPTIONS, cracks=Structure(2.0, (96, 96), periodic=True)),
    }
    assert key not in others and len(others) == 8


def _put_many(folder: str, key: str, analysis, times: int) -> None:
    store = AnalysisStore(folder)
    for _ in range(times):
        assert store.put(key, analysis)


def test_concurrent_writers_leave_a_whole_entry(tmp_path, analysis):
    """Two processes and two threads write one key at once while this one reads it: every read
    is a miss or a whole analysis, and the last file loads."""
    store, key = AnalysisStore(tmp_path), "k" * 64
    # (spawned, not forked: a fork of this many-threaded process (numba, Dask's offload thread)
    # can hang in the child before it runs, which once held a whole test run)
    context = multiprocessing.get_context("spawn")
    writers = [context.Process(target=_put_many, args=(str(tmp_path), key, analysis, 4)) for _ in range(2)]
    writers += [threading.Thread(target=_put_many, args=(str(tmp_path), key, analysis, 4)) for _ in range(2)]
    for writer in writers:
        writer.start()
    seen = []
    while any(w.is_alive() for w in writers):
        found = store.get(key)
        if found is not None:
            seen.append(np.array_equal(found.labels_in, analysis.labels_in))
    for writer in writers:
        writer.join()
    assert all(getattr(w, "exitcode", 0) == 0 for w in writers)
    assert all(seen)
    assert np.array_equal(store.get(key).labels_in, analysis.labels_in)
    assert [p.name for p in tmp_path.iterdir()] == [f"{key}.analysis"]  # no temporary left


def test_a_torn_or_damaged_file_is_a_miss_and_is_rebuilt(tmp_path, photo, analysis):
    store, hits = AnalysisStore(tmp_path), []
    cached_analysis(photo, OPTIONS, store=store)
    path = store.entries()[0].path
    size = path.stat().st_size
    with open(path, "r+b") as handle:  # a write cut short
        handle.truncate(size // 2)
    assert store.get(path.stem) is None and not path.exists()
    found = cached_analysis(photo, OPTIONS, store=store, on_hit=hits.append)
    assert not hits and path.stat().st_size == size and np.array_equal(found.labels_in, analysis.labels_in)
    with open(path, "r+b") as handle:  # one byte changed in the arrays
        handle.seek(size - 1000)
        byte = handle.read(1)
        handle.seek(size - 1000)
        handle.write(bytes([byte[0] ^ 0xFF]))
    assert store.get(path.stem) is None and not path.exists()
    path.write_bytes(b"not an analysis")
    assert store.get(path.stem) is None and not path.exists()


def test_an_upgraded_version_is_a_miss(tmp_path, photo, monkeypatch):
    store, hits = AnalysisStore(tmp_path), []
    cached_analysis(photo, OPTIONS, store=store)
    cached_analysis(photo, OPTIONS, store=store, on_hit=hits.append)
    assert len(hits) == 1
    upgraded = analysis_cache.cache_version() + ("numpy 99",)
    monkeypatch.setattr(analysis_cache, "cache_version", lambda: upgraded)
    cached_analysis(photo, OPTIONS, store=store, on_hit=hits.append)
    assert len(hits) == 1 and len(store.entries()) == 2
    # an entry of another file format (an older barkgen's, under the same key) is a miss too
    key = analysis_digest(photo, OPTIONS)
    monkeypatch.setattr(analysis_cache, "CACHE_FORMAT", analysis_cache.CACHE_FORMAT + 1)
    assert store.get(key) is None and not store.path(key).exists()


def test_eviction_removes_the_least_recently_used(tmp_path, analysis):
    size = len(b"".join(bytes(p) for p in analysis_cache._encode(analysis, {}))) + analysis_cache._HEADER.size
    store = AnalysisStore(tmp_path, max_bytes=int(2.5 * size))
    for age, key in ((300, "a"), (200, "b")):
        store.put(key, analysis)
        os.utime(store.path(key), (os.path.getmtime(store.path(key)) - age,) * 2)
    assert store.get("a") is not None  # a hit: "a" is now the most recently used
    assert store.put("c", analysis, wait=False)  # written on a thread
    store.flush()
    assert sorted(e.key for e in store.entries()) == ["a", "c"]
    assert not AnalysisStore(tmp_path, max_bytes=size // 2).put("d", analysis)  # larger than the bound
    assert store.clear() == (2, 2 * size) and store.entries() == []


def test_no_cache_and_the_environment_turn_it_off(tmp_path, monkeypatch):
    monkeypatch.setenv("BARKGEN_CACHE_DIR", str(tmp_path / "cache"))
    assert open_store().folder == tmp_path / "cache"
    assert open_store(enabled=False) is None
    monkeypatch.setenv("BARKGEN_NO_CACHE", "1")
    assert open_store() is None


def test_the_cli_reuses_the_analysis_for_another_seed_and_no_cache_writes_nothing(tmp_path, photo, monkeypatch):
    cache = tmp_path / "cache"
    monkeypatch.setenv("BARKGEN_CACHE_DIR", str(cache))
    source = tmp_path / "photo.png"
    write_png(source, photo)
    common = ["generate", str(source), "--size", "96x96", "--k", "3"]
    done = run_here(*common, "-o", str(tmp_path / "n"), "--seed", "2", "--no-cache")
    assert done.returncode == 0, done.stderr
    assert not cache.exists()
    first = run_here(*common, "-o", str(tmp_path / "a"), "--seed", "1")
    second = run_here(*common, "-o", str(tmp_path / "b"), "--seed", "2")
    assert first.returncode == second.returncode == 0, first.stderr + second.stderr
    assert "from the cache" not in first.stderr and "from the cache" in second.stderr
    assert len(AnalysisStore(cache).entries()) == 1
    for name in ("texture.png", "labels_out.png", "reference.png", "preview.png"):
        assert (tmp_path / "b" / name).read_bytes() == (tmp_path / "n" / name).read_bytes(), name
    shown = run_here("cache", "show")
    assert shown.returncode == 0
    cleared = run_here("cache", "clear")
    assert cleared.returncode == 0 and AnalysisStore(cache).entries() == []


def test_the_cache_command_prints_the_folder(tmp_path, monkeypatch, capsys):
    from barkgen.cli.cache import clear_command, show_command

    monkeypatch.setenv("BARKGEN_CACHE_DIR", str(tmp_path))
    show_command()
    clear_command()
    out = capsys.readouterr().out
    assert f"folder: {Path(tmp_path)}" in out and "entries: 0" in out and "removed 0 entries" in out


def test_an_entry_reads_back_whole_with_or_without_a_mapping(tmp_path, analysis, monkeypatch):
    """Read mapped (Linux) or into memory (elsewhere): the same arrays, writable as they were
    (a numba kernel types a read-only array apart, and would compile again)."""
    import mmap

    store = AnalysisStore(tmp_path)
    store.put("k", analysis)
    mapped = store.get("k")
    monkeypatch.delattr(mmap, "MAP_POPULATE", raising=False)
    read = store.get("k")
    for found in (mapped, read):
        assert np.array_equal(found.labels_in, analysis.labels_in) and found.labels_in.flags.writeable
        assert found.labels_in.flags.aligned
        assert np.array_equal(found.illumination, analysis.illumination)
