"""Batch generation on Dask (``barkgen.batch``, ``barkgen batch``): a whole spec on the default
LocalCluster, re-runs that do only what is missing, a worker killed mid-run, an interrupted
client, an external scheduler with two workers, byte-identity with ``barkgen generate``, and
bad specs refused before any work starts."""

from __future__ import annotations

import json
import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import run

from barkgen.io import read_image, write_png

#: images of a variant folder (report.json aside)
IMAGES = ("texture.png", "labels_in.png", "labels_out.png", "reference.png", "preview.png")
SEEDS = list(range(8))


@pytest.fixture(scope="module")
def photos(tmp_path_factory) -> Path:
    """Two bark photos (fir, pine) as 512 px PNGs in a folder with a spec beside them."""
    from conftest import bark_exemplar

    folder = tmp_path_factory.mktemp("forest")
    (folder / "photos").mkdir()
    for name, stem in (("fir", "fir_scaly_01"), ("pine", "pine_plated_01")):
        write_png(folder / "photos" / f"{name}.png", bark_exemplar(stem, 512))
    return folder


def write_spec(folder: Path, size: str, name: str = "spec.yaml", **extra) -> Path:
    doc = {
        "size": size,
        "tile": True,
        "k": 3,
        "material": False,
        "exemplars": [
            {"name": "fir", "path": "photos/fir.png", "seeds": SEEDS},
            {"name": "pine", "path": "photos/pine.png", "count": 8, "seed_base": 100},
        ],
    }
    doc.update(extra)
    path = folder / name
    path.write_text(json.dumps(doc))  # JSON is YAML
    return path


def variant_folders(out: Path) -> list[Path]:
    return sorted(p for p in out.glob("*/*") if p.is_dir())


def check_complete(out: Path, shape: tuple[int, int]) -> None:
    """Every variant present exactly once, complete, valid images; no staging left anywhere."""
    folders = variant_folders(out)
    expected = [out / "fir" / str(s) for s in SEEDS] + [out / "pine" / str(100 + s) for s in SEEDS]
    assert folders == sorted(expected)
    leftovers = [p for p in out.rglob("*") if p.name.startswith(".")]
    assert leftovers == []
    for folder in folders:
        report = json.loads((folder / "report.json").read_text())
        assert sorted(report["files"]) == sorted(p.name for p in folder.iterdir())
        assert report["seed"] == int(folder.name)
        texture = read_image(folder / "texture.png")
        assert texture.shape == shape + (3,) and texture.std() > 5
    with sqlite3.connect(out / "manifest.sqlite") as db:
        states = db.execute("SELECT state, COUNT(*) FROM variants GROUP BY state").fetchall()
    assert states == [("done", 16)]


def start_batch(
    spec: Path, out: Path, *args: str, env: dict | None = None, own_group: bool = False
) -> subprocess.Popen:
    """``barkgen batch`` in the background; ``own_group``: in a process group of its own, as a
    terminal runs it (its Ctrl-C then reaches the workers too). Ctrl-C is given back its default
    in the child: a suite started as a background job of a non-interactive shell inherits it
    ignored, and the batch would never see it."""
    return subprocess.Popen(
        [sys.executable, "-m", "barkgen", "batch", str(spec), "-o", str(out), *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, **(env or {})},
        start_new_session=own_group,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )


def wait_done(out: Path, count: int, proc: subprocess.Popen, timeout: float = 300) -> None:
    """Wait until the manifest records ``count`` finished variants."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        assert proc.poll() is None, proc.communicate()
        try:
            with sqlite3.connect(out / "manifest.sqlite", timeout=5) as db:
                n = db.execute("SELECT COUNT(*) FROM variants WHERE state = 'done'").fetchone()[0]
            if n >= count:
                return
        except sqlite3.OperationalError:  # not created yet
            pass
        time.sleep(0.2)
    raise AssertionError("the batch made no progress")


def test_forest_on_default_local_cluster_then_rerun_does_nothing(photos):
    spec = write_spec(photos, "256x256")
    out = photos / "out256"
    result = run("batch", str(spec), "-o", str(out))
    assert result.returncode == 0, result.stderr
    assert "Dask dashboard: http" in result.stderr and "made 16 variant(s)" in result.stderr
    check_complete(out, (256, 256))
    # every seed its own bark
    textures = [read_image(out / "fir" / str(s) / "texture.png").astype(np.int16) for s in (0, 1)]
    assert np.mean(textures[0] != textures[1]) > 0.5

    again = run("batch", str(spec), "-o", str(out))
    assert again.returncode == 0, again.stderr
    assert "nothing to do: all 16 variants are already in" in again.stderr
    assert "dashboard" not in again.stderr


@pytest.fixture(scope="module")
def local_small(photos) -> Path:
    """A small batch made on the LocalCluster through the Python API (the reference run)."""
    from barkgen.batch import load_spec, run_batch

    spec = write_spec(photos, "160x128", name="small.yaml")
    out = photos / "local"
    report = run_batch(load_spec(spec), out, workers=2)
    assert report.made == 16 and not report.failed and report.workers == 2
    assert set(report.analysis_seconds) == {"fir", "pine"}
    return out


def test_same_files_as_generate(photos, local_small):
    gen = photos / "gen"
    result = run(
        "generate",
        str(photos / "photos" / "pine.png"),
        "-o",
        str(gen),
        "--size",
        "160x128",
        "--tile",
        "--k",
        "3",
        "--seed",
        "103",
        "--quiet",
    )
    assert result.returncode == 0, result.stderr
    batch = local_small / "pine" / "103"
    assert sorted(p.name for p in gen.iterdir()) == sorted(p.name for p in batch.iterdir())
    for name in IMAGES:
        assert (gen / name).read_bytes() == (batch / name).read_bytes(), name
    a, b = (json.loads((d / "report.json").read_text()) for d in (gen, batch))
    for report in (a, b):
        report.pop("timings_s"), report.pop("photo")
    assert a == b


def test_worker_killed_mid_run_still_completes(photos, local_small):
    import psutil

    spec = write_spec(photos, "160x128", name="small.yaml")
    out = photos / "killed"
    proc = start_batch(spec, out, "--workers", "2")
    try:
        wait_done(out, 1, proc)
        children = [
            c for c in psutil.Process(proc.pid).children(recursive=True) if "spawn_main" in " ".join(c.cmdline())
        ]
        assert len(children) >= 2  # the worker processes of the local cluster
        victim = children[0]
        victim.send_signal(signal.SIGKILL)
        victim.wait(10)
        stdout, stderr = proc.communicate(timeout=600)
    finally:
        proc.kill()
    assert proc.returncode == 0, stderr
    check_complete(out, (128, 160))
    for folder in variant_folders(out):  # the same results as the undisturbed run
        ref = local_small / folder.parent.name / folder.name
        assert (folder / "texture.png").read_bytes() == (ref / "texture.png").read_bytes()


def test_every_worker_killed_after_the_first_variant_still_completes(photos, local_small):
    """Both workers are killed at once after the first variant, with every copy of the photos
    and analyses: the photos are made again from the graph (scattered data would be lost for
    good and the variants needing it cancelled)."""
    from distributed import Client

    from barkgen.batch import load_spec, run_batch
    from barkgen.batch.runner import local_cluster

    out = photos / "all_killed"
    killed = []
    with local_cluster(2, 1) as cluster, Client(cluster) as client:

        def kill_every_worker(done, total):
            if done == 1:
                for pid in client.run(os.getpid).values():
                    os.kill(pid, signal.SIGKILL)
                    killed.append(pid)

        report = run_batch(
            load_spec(write_spec(photos, "160x128", name="small.yaml")), out, progress=kill_every_worker, client=client
        )
    assert len(killed) == 2
    assert report.failed == [] and report.made == 16
    check_complete(out, (128, 160))
    for folder in variant_folders(out):
        ref = local_small / folder.parent.name / folder.name
        assert (folder / "texture.png").read_bytes() == (ref / "texture.png").read_bytes()


def test_interrupted_client_then_rerun_makes_only_the_rest(photos, local_small):
    spec = write_spec(photos, "160x128", name="small.yaml")
    out = photos / "interrupted"
    proc = start_batch(spec, out, "--workers", "2", own_group=True)
    try:
        wait_done(out, 2, proc)
        os.killpg(proc.pid, signal.SIGINT)  # Ctrl-C in a terminal: the whole group, workers too
        _, stderr = proc.communicate(timeout=120)
    finally:
        proc.kill()
    assert proc.returncode == 130, stderr
    # one line of ours (after the dashboard's), not every worker's traceback (141 lines)
    assert "interrupted" in stderr and "Traceback" not in stderr and len(stderr.splitlines()) <= 3
    finished = variant_folders(out)
    assert 2 <= len(finished) < 16
    assert [p for p in out.rglob("*") if p.name.startswith(".")] == []
    stamps = {p: (p / "report.json").stat().st_mtime_ns for p in finished}
    for folder in finished:  # whatever was written is whole
        assert sorted(json.loads((folder / "report.json").read_text())["files"]) == sorted(
            p.name for p in folder.iterdir()
        )

    again = run("batch", str(spec), "-o", str(out), "--workers", "2")
    assert again.returncode == 0, again.stderr
    done_before = len(finished)
    assert f"{done_before} of 16 variants already done; making the other {16 - done_before}" in again.stderr
    check_complete(out, (128, 160))
    assert {p: (p / "report.json").stat().st_mtime_ns for p in finished} == stamps


def test_external_scheduler_two_workers_same_results(photos, local_small, tmp_path):
    scheduler_file = tmp_path / "scheduler.json"
    env = {**os.environ, "NUMBA_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    procs = [
        subprocess.Popen(
            [
                sys.executable,
                "-m",
                "dask",
                "scheduler",
                "--host",
                "127.0.0.1",
                "--port",
                "0",
                "--no-dashboard",
                "--scheduler-file",
                str(scheduler_file),
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            env=env,
        )
    ]
    try:
        deadline = time.time() + 60
        while not scheduler_file.exists() and time.time() < deadline:
            time.sleep(0.2)
        address = json.loads(scheduler_file.read_text())["address"]
        assert address.startswith("tcp://127.0.0.1:")
        for _ in range(2):
            procs.append(
                subprocess.Popen(
                    [
                        sys.executable,
                        "-m",
                        "dask",
                        "worker",
                        address,
                        "--nthreads",
                        "1",
                        "--nworkers",
                        "1",
                        "--no-dashboard",
                        "--host",
                        "127.0.0.1",
                    ],
                    stdout=subprocess.DEVNULL,
                    stderr=subprocess.DEVNULL,
                    env=env,
                )
            )
        spec = write_spec(photos, "160x128", name="small.yaml")
        out = tmp_path / "external"
        result = run("batch", str(spec), "-o", str(out), "--scheduler", address, "--threads", "1")
        assert result.returncode == 0, result.stderr
        check_complete(out, (128, 160))
        with sqlite3.connect(out / "manifest.sqlite") as db:
            used = {w for (w,) in db.execute("SELECT DISTINCT worker FROM variants")}
        assert len(used) == 2  # both workers took variants
        for folder in variant_folders(out):
            ref = local_small / folder.parent.name / folder.name
            for name in IMAGES:
                assert (folder / name).read_bytes() == (ref / name).read_bytes(), (folder, name)
    finally:
        for p in procs:
            p.terminate()
        for p in procs:
            try:
                p.wait(20)
            except subprocess.TimeoutExpired:
                p.kill()


BAD_SPECS = [
    ({"sizse": "64x64"}, "unknown key 'sizse' (did you mean 'size'?)"),
    ({"sizes": "64x64"}, "sizes: '64x64' is no width"),
    ({"preset": "maya"}, "preset must be one of"),
    ({"exemplars": [{"name": "fir", "path": "photos/fir.png", "seed": [1]}]}, "unknown key 'seed'"),
    ({"exemplars": [{"name": "fir", "path": "photos/nope.png", "seeds": [1]}]}, "'photos/nope.png' not found"),
    ({"size": "0x0"}, "width and height must be positive"),
    ({"size": "abc"}, "invalid size 'abc'"),
    (
        {
            "exemplars": [
                {"name": "fir", "path": "photos/fir.png", "seeds": [1]},
                {"name": "fir", "path": "photos/pine.png", "seeds": [2]},
            ]
        },
        "also exemplars[0]'s",
    ),
    ({"exemplars": [{"name": "fir", "path": "photos/fir.png", "seeds": [1, 2, 1]}]}, "seed 1 is listed twice"),
    ({"exemplars": [{"name": "fir", "path": "photos/fir.png", "seeds": [1], "count": 3}]}, "not both"),
    ({"exemplars": [{"name": "fir", "path": "photos/fir.png"}]}, "seeds: [0, 1, ...] or count: N"),
    ({"exemplars": [{"name": "pine", "library": 7, "count": 8}]}, "no exemplar 7 in the library"),
    ({"exemplars": [{"name": "../up", "path": "photos/fir.png", "seeds": [1]}]}, "must be a folder name"),
    ({"exemplars": []}, "non-empty list"),
    ({"k": 99}, "spec: k"),
    ({"tile": "yes"}, "tile must be true or false"),
    (
        {"exemplars": [{"name": "fir", "path": "photos/fir.png", "seeds": [-1]}]},
        "seed must be an integer from 0 to 2**63 - 1",
    ),
    # issue 56: refused up front, not after the work or inside a worker
    ({"exemplars": [{"name": "fir", "path": "photos/fir.png", "seeds": [2**64]}]}, "2**63 - 1"),
    (
        {
            "exemplars": [
                {"name": "fir", "path": "photos/fir.png", "count": 60000},
                {"name": "pine", "path": "photos/pine.png", "count": 60000},
            ]
        },
        "120000 variants or more",
    ),
    ({"size": "99999x99999"}, "more than the limit"),
    # issue 67: the manifest's name is no exemplar's (refused before the cluster, not after it)
    ({"exemplars": [{"name": "manifest.sqlite", "path": "photos/fir.png", "seeds": [1]}]}, "the batch's manifest"),
]


@pytest.mark.parametrize("change,message", BAD_SPECS)
def test_bad_spec_one_line_before_any_work(photos, tmp_path, change, message):
    doc = {"size": "64x64", "exemplars": [{"name": "fir", "path": "photos/fir.png", "seeds": [0]}]}
    doc.update(change)
    spec = photos / f"bad-{abs(hash(message))}.yaml"
    spec.write_text(json.dumps(doc))
    out = tmp_path / "out"
    result = run("batch", str(spec), "-o", str(out))
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("barkgen: error: spec"), result.stderr
    assert message in lines[0]
    assert not out.exists()


def test_bad_yaml_and_missing_spec(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("size: 64x64\nexemplars: [{name: a, path: b\n")
    for spec, message in ((bad, "at line"), (tmp_path / "none.yaml", "not found")):
        result = run("batch", str(spec), "-o", str(tmp_path / "out"))
        assert result.returncode == 2 and message in result.stderr
        assert len(result.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists()


def test_bad_photo_or_unreachable_scheduler_one_line_nothing_written(photos, tmp_path):
    (tmp_path / "photos").mkdir()
    (tmp_path / "photos" / "fir.png").write_bytes(b"not a png at all")
    spec = tmp_path / "spec.yaml"
    spec.write_text(
        json.dumps({"size": "64x64", "exemplars": [{"name": "fir", "path": "photos/fir.png", "seeds": [0]}]})
    )
    out = tmp_path / "out"
    result = run("batch", str(spec), "-o", str(out))
    assert result.returncode == 2 and "exemplar 'fir'" in result.stderr, result.stderr
    assert len(result.stderr.strip().splitlines()) == 1 and not out.exists()

    good = write_spec(photos, "64x64", name="tiny.yaml")
    result = run("batch", str(good), "-o", str(out), "--scheduler", "tcp://127.0.0.1:9")
    assert result.returncode == 2 and "cannot reach the Dask scheduler" in result.stderr, result.stderr
    assert len(result.stderr.strip().splitlines()) == 1 and not out.exists()


def test_hostile_specs_are_refused_before_they_are_expanded(tmp_path):
    """A 400-byte YAML alias bomb and a 200,000-seed list used to hang validation for minutes:
    refused with little allocated (the bomb expanded is 9**9 items, 3 GB; the seeds parsed are
    9 MB, and no variant is made of them). How fast: benchmarks/bench_abuse.py."""
    import tracemalloc

    from barkgen.batch import load_spec
    from barkgen.errors import InvalidInputError

    (tmp_path / "p.png").write_bytes(b"")
    bomb = tmp_path / "bomb.yaml"
    levels = ["a: &a [x, x, x, x, x, x, x, x, x]"]
    for i, name in enumerate("bcdefghi"):
        prev = "abcdefghi"[i]
        levels.append(f"{name}: &{name} [{', '.join(['*' + prev] * 9)}]")
    bomb.write_text("\n".join(levels) + "\nexemplars: [{name: a, path: p.png, seeds: *i}]\n")
    many = tmp_path / "many.yaml"
    many.write_text(json.dumps({"exemplars": [{"name": "a", "path": "p.png", "seeds": list(range(200_000))}]}))
    for spec, message, bound in ((bomb, "aliases", 2**20), (many, "more than 100000", 32 * 2**20)):
        with pytest.raises(InvalidInputError, match=message):
            load_spec(spec)  # (its imports, not counted below)
        tracemalloc.start()
        try:
            with pytest.raises(InvalidInputError, match=message):
                load_spec(spec)
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        assert peak < bound, (spec.name, peak)


def test_a_damaged_manifest_is_one_line(tmp_path):
    from barkgen.batch.manifest import Manifest
    from barkgen.errors import InvalidInputError

    damaged = tmp_path / "manifest.sqlite"
    damaged.write_bytes(np.random.default_rng(0).bytes(5000))
    with pytest.raises(InvalidInputError, match="not a readable batch manifest"):
        Manifest(damaged)


def run_without_dask(monkeypatch, *args: str) -> tuple[subprocess.CompletedProcess, list]:
    """``barkgen ARGS`` in this process (:func:`barkgen.cli.main`), the Dask client it asks for
    recorded and never made: ``(what run() returns, the clients asked for)``."""
    from conftest import run_here

    import barkgen.batch.runner

    asked: list = []

    def no_client(*client_args):
        asked.append(client_args)
        raise RuntimeError("a Dask client was asked for")

    monkeypatch.setattr(barkgen.batch.runner, "_client", no_client)
    return run_here(*args), asked


def test_a_variant_folder_holding_the_users_files_is_refused_before_any_work(photos, tmp_path, monkeypatch):
    """An exemplar named like a folder of the user's under the output (its photo and notes in
    OUT/<name>/<seed>/): refused in one line before the cluster starts (no Dask client asked
    for), nothing touched."""
    spec = tmp_path / "spec.yaml"
    spec.write_text(
        json.dumps(
            {"size": "64x64", "exemplars": [{"name": "fir", "path": str(photos / "photos" / "fir.png"), "seeds": [0]}]}
        )
    )
    mine = tmp_path / "out" / "fir" / "0"
    mine.mkdir(parents=True)
    (mine / "fir.jpg").write_bytes(b"the user's photo")
    (mine / "notes.txt").write_text("mine")
    result, asked = run_without_dask(monkeypatch, "batch", str(spec), "-o", str(tmp_path / "out"))
    assert result.returncode == 2 and "barkgen did not write" in result.stderr, result.stderr
    assert len(result.stderr.strip().splitlines()) == 1 and asked == []
    assert sorted(p.name for p in mine.iterdir()) == ["fir.jpg", "notes.txt"]
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["fir"]


def test_a_manifest_that_is_no_file_is_refused_before_the_cluster(photos, tmp_path, monkeypatch):
    """OUT/manifest.sqlite a folder: one line before any Dask client is asked for (issue 67: it
    was refused after the cluster had started, 4.2 s)."""
    spec = tmp_path / "spec.yaml"
    spec.write_text(
        json.dumps(
            {"size": "64x64", "exemplars": [{"name": "fir", "path": str(photos / "photos" / "fir.png"), "seeds": [0]}]}
        )
    )
    (tmp_path / "out" / "manifest.sqlite").mkdir(parents=True)
    result, asked = run_without_dask(monkeypatch, "batch", str(spec), "-o", str(tmp_path / "out"))
    assert result.returncode == 2 and "manifest is not a file" in result.stderr, result.stderr
    assert len(result.stderr.strip().splitlines()) == 1 and asked == []
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["manifest.sqlite"]


@pytest.mark.parametrize(
    "address,message",
    [
        ("tcp://256.1.1.1:99999", "port 99999"),
        ("tcp://256.1.1.1:8786", "not an IP address"),
        ("not-a-url", "tcp://HOST:PORT"),
        ("", "tcp://HOST:PORT"),
        ("http://host:8786", "tcp://HOST:PORT"),
    ],
)
def test_a_malformed_scheduler_address_is_refused_at_once(photos, tmp_path, monkeypatch, address, message):
    """Not after a 20 s connection timeout (tcp://256.1.1.1:99999 took 21 s): refused before a
    Dask client is asked for (and never as an internal error)."""
    spec = write_spec(photos, "64x64", name="addr.yaml")
    result, asked = run_without_dask(
        monkeypatch, "batch", str(spec), "-o", str(tmp_path / "out"), "--scheduler", address
    )
    assert result.returncode == 2 and message in result.stderr, result.stderr
    assert len(result.stderr.strip().splitlines()) == 1 and asked == []
    assert not (tmp_path / "out").exists()


def test_another_programs_manifest_is_neither_changed_nor_trusted(photos, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    db = sqlite3.connect(out / "manifest.sqlite")
    db.execute("CREATE TABLE variants (foo TEXT)")
    db.execute("CREATE TABLE other (x)")
    db.commit()
    db.close()
    before = (out / "manifest.sqlite").read_bytes()
    result = run("batch", str(write_spec(photos, "64x64", name="m.yaml")), "-o", str(out))
    assert result.returncode == 2 and "not a barkgen batch manifest" in result.stderr, result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
    assert (out / "manifest.sqlite").read_bytes() == before and sorted(p.name for p in out.iterdir()) == [
        "manifest.sqlite"
    ]


def test_a_scanned_set_folder_with_a_preset_and_sizes_makes_generates_files(tmp_path):
    """A spec's ``path`` may be a scanned set's folder (issue 32); ``preset`` and ``sizes`` are
    spec keys; the variant's files are ``barkgen generate SETDIR``'s with the same flags."""
    from conftest import BARK, BARK_MAPS

    from barkgen.batch import load_spec, run_batch

    maps = BARK_MAPS
    folder = tmp_path / "pineset"
    folder.mkdir()
    write_png(folder / "pine_plated_01.png", read_image(BARK / "pine_plated_01.jpg")[:128, :128])
    for kind in ("normal", "ao", "roughness"):
        write_png(folder / f"pine_plated_01_{kind}.png", read_image(maps / f"pine_plated_01_{kind}.jpg")[:128, :128])
    spec = tmp_path / "spec.yaml"
    spec.write_text(
        json.dumps(
            {
                "size": "128x96",
                "tile": True,
                "preset": "unreal",
                "sizes": ["64", "128"],
                "exemplars": [{"path": "pineset", "seeds": [2]}],
            }
        )
    )
    out = tmp_path / "out"
    report = run_batch(load_spec(spec), out, workers=1)
    assert report.failed == [] and report.made == 1
    gen = tmp_path / "gen"
    flags = ["--size", "128x96", "--tile", "--seed", "2", "--preset", "unreal", "--sizes", "64,128", "-q"]
    r = run("generate", str(folder), "-o", str(gen), *flags)
    assert r.returncode == 0, r.stderr
    batch = out / "pineset" / "2"
    names = sorted(p.name for p in gen.iterdir())
    assert names == sorted(p.name for p in batch.iterdir())
    # the scanned set's own name, the seed, each size (64x48: no power of two)
    assert "pine_plated_01_seed2_64x48_ORM.png" in names and "pine_plated_01_seed2_128x96_NormalDX.png" in names
    for name in names:
        if name.endswith(".png"):
            assert (gen / name).read_bytes() == (batch / name).read_bytes(), name


def test_a_spec_mixing_plain_cracks_and_bilayer_resumes_after_ctrl_c(tmp_path):
    """One spec, three kinds of bark: the photo's labels in new shapes, a grown crack network
    (``structure: cracks``) and a bi-layer texture (``model: bilayer``), on the LocalCluster;
    Ctrl-C after the first variants, then the rerun makes only the rest, and each variant's
    report says what it is."""
    from conftest import BARK, bark_exemplar, crack_photo

    (tmp_path / "photos").mkdir()
    write_png(tmp_path / "photos" / "fir.png", bark_exemplar("fir_scaly_01", 160))
    write_png(tmp_path / "photos" / "lichen.png", read_image(BARK / "lichen_covered_01.jpg")[:160, :160])
    mud = crack_photo(256, 0)  # a drawn crack network (the team's dried mud photo is copyleft)
    write_png(tmp_path / "photos" / "mud.png", mud)
    doc = {
        "size": "128x96",
        "tile": True,
        "k": 2,
        "exemplars": [
            {"name": "fir", "path": "photos/fir.png", "count": 4},
            {"name": "mud", "path": "photos/mud.png", "count": 4, "structure": "cracks"},
            {"name": "lichen", "path": "photos/lichen.png", "count": 4, "model": "bilayer"},
        ],
    }
    spec = tmp_path / "mixed.yaml"
    spec.write_text(json.dumps(doc))
    out = tmp_path / "out"
    proc = start_batch(spec, out, "--workers", "2", own_group=True)
    try:
        wait_done(out, 2, proc)
        os.killpg(proc.pid, signal.SIGINT)
        _, stderr = proc.communicate(timeout=120)
    finally:
        proc.kill()
    assert proc.returncode == 130, stderr
    finished = len(variant_folders(out))
    assert 2 <= finished < 12
    again = run("batch", str(spec), "-o", str(out), "--workers", "2")
    assert again.returncode == 0, again.stderr
    assert f"{finished} of 12 variants already done" in again.stderr
    kinds = {}
    for folder in variant_folders(out):
        report = json.loads((folder / "report.json").read_text())
        kinds.setdefault(folder.parent.name, set()).add((report["structure"], report["model"]))
        assert read_image(folder / "texture.png").shape == (96, 128, 3)
    assert kinds == {
        "fir": {("labels", "patches")},
        "mud": {("cracks", "patches")},
        "lichen": {("labels", "bilayer")},
    }
    assert set(np.unique(read_image(out / "mud" / "0" / "labels_out.png"))) == {0, 255}
