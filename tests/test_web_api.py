"""The web app's JSON API (FastAPI TestClient): limits and bad input, unknown ids, jobs in
order under load, cancel, events, painted labels, and results that outlive the server."""

from __future__ import annotations

import base64
import io
import json
import threading
import time
import zipfile

import numpy as np
import pytest
from fastapi.testclient import TestClient

from barkgen.io import encode_png
from barkgen.library import Library
from barkgen.web import WebLimits, create_app

SMALL = {"size": "96x96", "k": 2, "tile": False, "material": False}


def _photo_png(size: int = 128, seed: int = 0) -> bytes:
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:size, 0:size]
    stripes = 128 + 80 * np.sin(x / 4.0 + rng.normal(0, 0.3, (size, size)))
    image = np.stack([stripes, stripes * 0.7, stripes * 0.5], -1) + rng.normal(0, 10, (size, size, 3))
    return encode_png(np.clip(image, 0, 255).astype(np.uint8))


def _wait(client, job_id: str, timeout: float = 180) -> dict:
    deadline = time.monotonic() + timeout
    while True:
        job = client.get(f"/api/jobs/{job_id}").json()
        if job["state"] in ("done", "failed", "cancelled"):
            return job
        assert time.monotonic() < deadline, job
        time.sleep(0.1)


@pytest.fixture()
def library(tmp_path):
    return Library(tmp_path / "lib")


@pytest.fixture()
def client(library):
    with TestClient(create_app(library, limits=WebLimits(max_upload_bytes=2 * 1024**2,
                                                         max_upload_pixels=1_500_000))) as c:
        yield c


def test_upload_limits_and_content_checks(client, library, tmp_path):
    # over the byte limit: 413, by the declared length and by what arrives
    big = b"\x89PNG" + bytes(3 * 1024**2)
    r = client.post("/api/exemplars", files={"file": ("big.png", big)})
    assert r.status_code == 413 and "25 MB" not in r.json()["detail"] and "2 MB" in r.json()["detail"]
    # over the pixel limit (a small file of a large image): 413 before decoding
    huge = encode_png(np.zeros((1300, 1300, 3), np.uint8))
    assert len(huge) < 2 * 1024**2
    r = client.post("/api/exemplars", files={"file": ("huge.png", huge)})
    assert r.status_code == 413 and "megapixels" in r.json()["detail"]
    # not an image, whatever its name says: 400; an empty file: 400; a truncated PNG: 400
    for payload in (b"just some text, not a picture", b"", _photo_png()[:200]):
        r = client.post("/api/exemplars", files={"file": ("bark.jpg", payload)})
        assert r.status_code == 400, r.text
        assert r.json()["detail"]
    # the client's file name never becomes a path: only content hashes are written
    r = client.post("/api/exemplars", files={"file": ("../../../../tmp/evil.png", _photo_png())})
    assert r.status_code == 201
    exemplar = client.get(f"/api/exemplars/{r.json()['id']}").json()
    assert exemplar["name"] == "evil" and exemplar["source"] == "uploaded"
    written = [p for p in library.path.rglob("*") if p.is_file()]
    assert all(p.name == "library.sqlite" or p.name.startswith("library.sqlite-")
               or len(p.parent.name + p.name) == 64 for p in written), written
    assert not (tmp_path / "evil.png").exists()
    # only the exemplars that were accepted are listed (the sample and this one)
    assert len(client.get("/api/exemplars").json()) == 2


def test_unknown_ids_are_404(client):
    for path in ("/api/exemplars/999", "/api/exemplars/999/photo", "/api/exemplars/999/labels.png",
                 "/api/results/999", "/api/results/999/download", "/api/results/999/files/texture.png",
                 "/api/jobs/nope", "/api/jobs/nope/events", "/exemplars/999", "/results/999"):
        r = client.get(path)
        assert r.status_code == 404, path
        assert r.json()["detail"]
    assert client.delete("/api/jobs/nope").status_code == 404
    r = client.post("/api/jobs", json={"exemplar_id": 999, **SMALL})
    assert r.status_code == 404
    r = client.post("/api/jobs", json={"exemplar_id": 1, **SMALL, "size": "huge"})
    assert r.status_code == 400 and "size" in r.json()["detail"]
    r = client.post("/api/jobs", json={"exemplar_id": 1, **SMALL, "size": "9000x100"})
    assert r.status_code == 400 and "4096" in r.json()["detail"]


def test_five_jobs_at_once_complete_in_order(client, library):
    exemplar_id = client.post("/api/exemplars", files={"file": ("a.png", _photo_png())}).json()["id"]
    ids, errors = [None] * 5, []

    def submit(i: int) -> None:
        time.sleep(0.01 * i)  # five requests in flight together, in a known order
        r = client.post("/api/jobs", json={"exemplar_id": exemplar_id, **SMALL, "seed": 100 + i})
        if r.status_code != 201:
            errors.append(r.text)
        ids[i] = r.json()["id"]

    threads = [threading.Thread(target=submit, args=(i,)) for i in range(5)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors and all(ids)
    # the queue shows positions while they wait
    queued = [j for j in client.get("/api/jobs").json() if j["state"] == "queued"]
    assert [j["queue_position"] for j in queued] == sorted(j["queue_position"] for j in queued)
    jobs = [_wait(client, job_id) for job_id in ids]
    assert [j["state"] for j in jobs] == ["done"] * 5, [j["error"] for j in jobs]
    # the server's submission numbers give the order: results were made in that order
    by_number = sorted(jobs, key=lambda j: j["number"])
    assert [j["result_id"] for j in by_number] == sorted(j["result_id"] for j in jobs), \
        "jobs finished out of submission order"
    results = {r["id"]: r for r in client.get("/api/results").json()}
    assert {j["result_id"] for j in jobs} <= set(results)
    assert sorted(results[j["result_id"]]["params"]["seed"] for j in jobs) == [100, 101, 102, 103, 104]
    # each result has its files, and a reproducible texture: same seed twice -> same bytes
    again = _wait(client, client.post("/api/jobs", json={"exemplar_id": exemplar_id, **SMALL,
                                                           "seed": 102}).json()["id"])
    first = next(j for j in jobs if results[j["result_id"]]["params"]["seed"] == 102)
    texture = lambda rid: client.get(f"/api/results/{rid}/files/texture.png").content  # noqa: E731
    assert texture(again["result_id"]) == texture(first["result_id"])


def test_events_cancel_and_restart_keeps_results(library):
    app = create_app(library)
    with TestClient(app) as client:
        exemplar_id = client.post("/api/exemplars", files={"file": ("a.png", _photo_png(seed=3))}).json()["id"]
        done_id = client.post("/api/jobs", json={"exemplar_id": exemplar_id, **SMALL, "seed": 1}).json()["id"]
        # a long job behind it, and one behind that which is cancelled while queued
        long_id = client.post("/api/jobs", json={"exemplar_id": exemplar_id, **SMALL, "size": "1024x1024",
                                                 "seed": 2}).json()["id"]
        queued_id = client.post("/api/jobs", json={"exemplar_id": exemplar_id, **SMALL, "seed": 3}).json()["id"]
        assert client.get(f"/api/jobs/{queued_id}").json()["queue_position"] >= 1
        assert client.delete(f"/api/jobs/{queued_id}").json()["state"] == "cancelled"
        # the event stream of the first job: JSON states until it is done
        states = []
        with client.stream("GET", f"/api/jobs/{done_id}/events") as stream:
            for line in stream.iter_lines():
                if line.startswith("data: "):
                    states.append(json.loads(line[6:]))
        assert states[-1]["state"] == "done" and states[-1]["result_id"]
        progress = [s["progress"] for s in states]
        assert progress == sorted(progress)
        # cancel the long one while it runs: the worker is ended, the job says cancelled
        deadline = time.monotonic() + 60
        while client.get(f"/api/jobs/{long_id}").json()["state"] != "running":
            assert time.monotonic() < deadline
            time.sleep(0.05)
        assert client.delete(f"/api/jobs/{long_id}").status_code == 200
        assert _wait(client, long_id, timeout=30)["state"] == "cancelled"
        assert client.get(f"/api/jobs/{queued_id}").json()["result_id"] is None
        # the next job runs on a new worker
        after = _wait(client, client.post("/api/jobs", json={"exemplar_id": exemplar_id, **SMALL,
                                                              "seed": 4}).json()["id"])
        assert after["state"] == "done"
        before_restart = {r["id"] for r in client.get("/api/results").json()}
    assert len(before_restart) == 2
    # a new server on the same library lists the same results, with their files
    with TestClient(create_app(Library(library.path))) as client:
        assert {r["id"] for r in client.get("/api/results").json()} == before_restart
        for result_id in before_restart:
            archive = zipfile.ZipFile(io.BytesIO(client.get(f"/api/results/{result_id}/download").content))
            assert "texture.png" in archive.namelist() and "report.json" in archive.namelist()


def test_painted_labels_are_checked_then_continued(client):
    exemplar_id = client.post("/api/exemplars", files={"file": ("a.png", _photo_png(seed=5))}).json()["id"]
    job = _wait(client, client.post("/api/jobs", json={"exemplar_id": exemplar_id, **SMALL,
                                                        "seed": 7}).json()["id"])
    result = client.get(f"/api/results/{job['result_id']}").json()
    level = next(lv for lv in result["levels"] if lv["level"] == 1)
    coloured = client.get(level["url"])
    from barkgen.io import decode_image

    painted = decode_image(coloured.content).copy()
    palette = np.array(result["palette"], np.uint8)
    assert {tuple(c) for c in painted.reshape(-1, 3)} <= {tuple(c) for c in palette}

    def request(image, **changes):
        url = "data:image/png;base64," + base64.b64encode(encode_png(image)).decode()
        body = {"exemplar_id": exemplar_id, **SMALL, "seed": 7,
                "resume": {"result_id": result["id"], "level": 1, "labels": url}}
        body.update(changes)
        return client.post("/api/jobs", json=body)

    off = painted.copy()
    off[3, 5] = (1, 2, 3)
    r = request(off)
    assert r.status_code == 400 and "x=5, y=3" in r.json()["detail"]
    r = request(painted[:-1])
    assert r.status_code == 400 and "level 1" in r.json()["detail"]
    r = request(painted, size="128x128")
    assert r.status_code == 400 and "keeps its size" in r.json()["detail"]
    r = request(painted, resume={"result_id": result["id"], "level": 1, "labels": "data:text/plain,hi"})
    assert r.status_code == 400
    # a painted block of label 0 comes back in the continued label map
    painted[8:24, 8:24] = palette[0]
    continued = _wait(client, request(painted).json()["id"])
    assert continued["state"] == "done"
    second = client.get(f"/api/results/{continued['result_id']}").json()
    assert second["params"]["resumed_from"] == {"result_id": result["id"], "level": 1}
    assert second["parent_id"] == result["id"]
    labels = decode_image(client.get(second["files"]["labels_out.png"]).content)[..., 0]
    values = np.unique(decode_image(client.get(result["files"]["labels_in.png"]).content))
    parent = decode_image(client.get(result["files"]["labels_out.png"]).content)[..., 0]
    block = np.s_[16:48, 16:48]  # the painted block at full size (level 1 is half size)
    before, after = np.mean(parent[block] == values[0]), np.mean(labels[block] == values[0])
    assert after > 0.6 and after > before + 0.3, (before, after)
