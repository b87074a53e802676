"""The web app's JSON API (FastAPI TestClient): limits and bad input, unknown ids, jobs in
order under load, cancel, events, painted labels, and results that outlive the server."""

from __future__ import annotations

import base64
import io
import json
import re
import threading
import time
import zipfile

import numpy as np
import pytest
from fastapi.testclient import TestClient

from barkgen import Canvas
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
    with TestClient(
        create_app(library, limits=WebLimits(max_upload_bytes=2 * 1024**2, max_upload_pixels=1_500_000))
    ) as c:
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
    for payload in (
        b"just some text, not a picture",
        b"",
        _photo_png()[:200],
        encode_png(np.zeros((1, 1, 3), np.uint8)),
    ):  # a 1x1 photo is no bark
        r = client.post("/api/exemplars", files={"file": ("bark.jpg", payload)})
        assert r.status_code == 400, r.text
        assert r.json()["detail"]
    # the client's file name never becomes a path: only content hashes are written
    r = client.post("/api/exemplars", files={"file": ("../../../../tmp/evil.png", _photo_png())})
    assert r.status_code == 201
    exemplar = client.get(f"/api/exemplars/{r.json()['id']}").json()
    assert exemplar["name"] == "evil" and exemplar["source"] == "uploaded"
    # the same photo again: its entry, and the answer says so
    again = client.post("/api/exemplars", files={"file": ("other.png", _photo_png())}, data={"name": "x"})
    assert again.status_code == 200 and again.json() == {"id": r.json()["id"], "existing": True}
    assert r.json()["existing"] is False
    written = [p for p in library.path.rglob("*") if p.is_file()]
    assert all(
        p.name == "library.sqlite" or p.name.startswith("library.sqlite-") or len(p.parent.name + p.name) == 64
        for p in written
    ), written
    assert not (tmp_path / "evil.png").exists()
    # a tiny file of a huge image (a decompression bomb): 413, nothing decoded
    from PIL import Image

    bomb = io.BytesIO()
    Image.new("L", (20000, 20000)).save(bomb, "PNG")
    r = client.post("/api/exemplars", files={"file": ("bomb.png", bomb.getvalue())})
    assert r.status_code == 413, r.text
    # a body with no declared length (chunked) is cut off at the limit, multipart or JSON
    boundary = "barkgenboundary"

    def chunked_upload():
        yield (
            f'--{boundary}\r\nContent-Disposition: form-data; name="file"; filename="x.png"\r\n'
            "Content-Type: image/png\r\n\r\n"
        ).encode()
        for _ in range(64):  # 4 MB, twice the limit
            yield bytes(64 * 1024)
        yield f"\r\n--{boundary}--\r\n".encode()

    r = client.post(
        "/api/exemplars",
        content=chunked_upload(),
        headers={"content-type": f"multipart/form-data; boundary={boundary}"},
    )
    assert r.status_code == 413 and "2 MB" in r.json()["detail"]
    r = client.post(
        "/api/jobs", content=(b" " * 65536 for _ in range(64)), headers={"content-type": "application/json"}
    )
    assert r.status_code == 413
    # only the exemplars that were accepted are listed (the sample and this one)
    assert len(client.get("/api/exemplars").json()) == 2
    r = client.post("/api/exemplars", files={"file": ("a.png", _photo_png(seed=9))}, data={"species": "x" * 600})
    assert r.status_code == 400 and "species" in r.json()["detail"]


def test_hosts_and_cross_site_requests_are_refused(library):
    app = create_app(library, hosts=["127.0.0.1", "localhost"], run_jobs=False)
    with TestClient(app, base_url="http://127.0.0.1:8000") as client:
        assert client.get("/api/exemplars").status_code == 200
        # DNS rebinding: a page of evil.example that resolves to this machine
        r = client.get("/api/exemplars", headers={"host": "evil.example"})
        assert r.status_code == 400 and "unknown host" in r.json()["detail"]
        # another site's page posting here (no preflight for a form upload)
        r = client.post(
            "/api/exemplars", files={"file": ("a.png", _photo_png())}, headers={"origin": "http://evil.example"}
        )
        assert r.status_code == 403
        r = client.delete("/api/exemplars/1", headers={"origin": "http://localhost:9999"})
        assert r.status_code == 403 and client.get("/api/exemplars/1").status_code == 200
        # GETs start work too (a label map of a large photo): another site's <img> or fetch
        # of the API is refused, by its Sec-Fetch-Site (an <img> sends no Origin) or its Origin
        for headers in (
            {"sec-fetch-site": "cross-site"},
            {"sec-fetch-site": "same-site"},
            {"origin": "http://evil.example"},
        ):
            r = client.get("/api/exemplars/1/labels.png", headers=headers)
            assert r.status_code == 403, headers
        for headers in ({"sec-fetch-site": "same-origin"}, {"sec-fetch-site": "none"}, {}):
            assert client.get("/api/exemplars", headers=headers).status_code == 200, headers
        # a link from elsewhere to a page still opens it
        assert client.get("/", headers={"sec-fetch-site": "cross-site"}).status_code == 200
        # the app's own pages may
        r = client.post(
            "/api/exemplars", files={"file": ("a.png", _photo_png())}, headers={"origin": "http://127.0.0.1:8000"}
        )
        assert r.status_code == 201
        # seeds beyond 64 bits are refused at once; the queue is bounded
        r = client.post("/api/jobs", json={"exemplar_id": 1, **SMALL, "seed": 2**64})
        assert r.status_code == 422
        from barkgen.web.jobs import MAX_QUEUED

        codes = [
            client.post("/api/jobs", json={"exemplar_id": 1, **SMALL, "seed": i}).status_code
            for i in range(MAX_QUEUED + 1)
        ]
        assert codes == [201] * MAX_QUEUED + [429]
        # a full queue refuses a job, never an upload (its label job is asked for again by its
        # page; issue 67: the photo was stored and the upload answered 429)
        client.app.state.barkgen.jobs.eager = True  # (the server's: an upload queues its label map)
        r = client.post("/api/exemplars", files={"file": ("b.png", _photo_png(seed=9))})
        assert r.status_code == 201 and r.json()["existing"] is False, r.text


def test_unknown_ids_are_404(client):
    for path in (
        "/api/exemplars/999",
        "/api/exemplars/999/photo",
        "/api/exemplars/999/labels.png",
        "/api/results/999",
        "/api/results/999/download",
        "/api/results/999/files/texture.png",
        "/api/jobs/nope",
        "/api/jobs/nope/events",
    ):
        r = client.get(path)
        assert r.status_code == 404, path
        assert r.json()["detail"]
    # ids beyond SQLite's 64-bit integers name nothing either (they were HTTP 500, OverflowError)
    huge = "99999999999999999999"
    for path in (
        f"/api/exemplars/{huge}",
        f"/api/exemplars/{huge}/photo",
        f"/api/exemplars/{huge}/thumbnail.jpg",
        f"/api/exemplars/{huge}/labels.png",
        f"/api/results/{huge}",
        f"/api/results/{huge}/download",
        f"/api/results/{huge}/files/texture.png",
        f"/api/results?exemplar_id={huge}",
    ):
        r = client.get(path)
        assert r.status_code in (200, 404), (path, r.status_code)
        if path.startswith("/api/results?"):
            assert r.json() == [] or r.json().get("results") == [], path
    assert client.post("/api/jobs", json={"exemplar_id": int(huge), **SMALL}).status_code in (404, 422)
    # no page loads its scripts from a CDN: FastAPI's /docs and /redoc are off, the schema stays
    assert client.get("/docs").status_code == 404 and client.get("/redoc").status_code == 404
    assert client.get("/openapi.json").status_code == 200
    # the pages themselves load and say so (from the API's 404)
    for path in ("/exemplars/999", "/results/abc"):
        r = client.get(path)
        assert r.status_code == 200 and r.headers["content-type"].startswith("text/html")
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
    # the queue shows, for each waiting job, how many are ahead of it (the running one too)
    listed = client.get("/api/jobs").json()
    waiting = [j for j in listed if j["state"] == "queued"]
    running = sum(j["state"] == "running" for j in listed)
    assert [j["queue_position"] for j in waiting] == list(range(running, running + len(waiting)))
    jobs = [_wait(client, job_id) for job_id in ids]
    assert [j["state"] for j in jobs] == ["done"] * 5, [j["error"] for j in jobs]
    # the server's submission numbers give the order: results were made in that order
    by_number = sorted(jobs, key=lambda j: j["number"])
    assert [j["result_id"] for j in by_number] == sorted(j["result_id"] for j in jobs), (
        "jobs finished out of submission order"
    )
    results = {r["id"]: r for r in client.get("/api/results").json()}
    assert {j["result_id"] for j in jobs} <= set(results)
    assert sorted(results[j["result_id"]]["params"]["seed"] for j in jobs) == [100, 101, 102, 103, 104]
    # each result has its files, and a reproducible texture: same seed twice -> same bytes
    again = _wait(
        client, client.post("/api/jobs", json={"exemplar_id": exemplar_id, **SMALL, "seed": 102}).json()["id"]
    )
    first = next(j for j in jobs if results[j["result_id"]]["params"]["seed"] == 102)
    texture = lambda rid: client.get(f"/api/results/{rid}/files/texture.png").content  # noqa: E731
    assert texture(again["result_id"]) == texture(first["result_id"])


def test_events_cancel_and_restart_keeps_results(library):
    app = create_app(library)
    with TestClient(app) as client:
        exemplar_id = client.post("/api/exemplars", files={"file": ("a.png", _photo_png(seed=3))}).json()["id"]
        done_id = client.post("/api/jobs", json={"exemplar_id": exemplar_id, **SMALL, "seed": 1}).json()["id"]
        # a long job behind it, and one behind that which is cancelled while queued
        long_id = client.post(
            "/api/jobs", json={"exemplar_id": exemplar_id, **SMALL, "size": "2048x2048", "seed": 2}
        ).json()["id"]
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
        # a running job names its stage (the progress bar's text); a finished one does not
        stages = [s["stage"] for s in states if s["state"] == "running" and s["progress"] > 0]
        assert stages and all(isinstance(name, str) and name for name in stages)
        assert states[-1]["stage"] is None
        # cancel the long one while it runs: the worker is ended, the job says cancelled
        deadline = time.monotonic() + 60
        while client.get(f"/api/jobs/{long_id}").json()["state"] != "running":
            assert time.monotonic() < deadline
            time.sleep(0.05)
        assert client.delete(f"/api/jobs/{long_id}").status_code == 200
        assert _wait(client, long_id, timeout=30)["state"] == "cancelled"
        assert client.get(f"/api/jobs/{queued_id}").json()["result_id"] is None
        # the next job runs on a new worker
        after = _wait(
            client, client.post("/api/jobs", json={"exemplar_id": exemplar_id, **SMALL, "seed": 4}).json()["id"]
        )
        assert after["state"] == "done"
        before_restart = {r["id"] for r in client.get("/api/results").json()}
        assert len(before_restart) == 2
        # removing a photo cancels its jobs
        running_id = client.post(
            "/api/jobs", json={"exemplar_id": exemplar_id, **SMALL, "size": "2048x2048", "seed": 5}
        ).json()["id"]
        other = client.post("/api/exemplars", files={"file": ("b.png", _photo_png(seed=4))}).json()["id"]
        doomed = client.post("/api/jobs", json={"exemplar_id": other, **SMALL, "seed": 6}).json()["id"]
        assert client.delete(f"/api/exemplars/{other}").status_code == 200
        assert client.get(f"/api/jobs/{doomed}").json()["state"] == "cancelled"
        client.delete(f"/api/jobs/{running_id}")
        assert _wait(client, running_id, timeout=30)["state"] == "cancelled"
    # a new server on the same library lists the same results, with their files
    with TestClient(create_app(Library(library.path))) as client:
        assert {r["id"] for r in client.get("/api/results").json()} == before_restart
        for result_id in before_restart:
            download = client.get(f"/api/results/{result_id}/download")
            named = re.search(r'filename="(a_seed\d+_96x96)\.zip"', download.headers["content-disposition"])
            assert named, download.headers["content-disposition"]
            archive = zipfile.ZipFile(io.BytesIO(download.content))
            set_name = named.group(1)
            assert {f"{set_name}_{n}" for n in ("texture.png", "report.json", "README.txt")} <= set(archive.namelist())
            assert not any("level_" in n for n in archive.namelist())
            assert f"{set_name}_reference.png" in archive.read(f"{set_name}_README.txt").decode()


def test_label_maps_are_made_by_jobs_in_the_worker_never_in_a_request(library):
    """A photo's label map is a label job (queued ahead of generate jobs, shared, cancellable);
    a GET only reads it (it was computed inside the GET, in the server process)."""
    with TestClient(create_app(library, run_jobs=False)) as client:
        r = client.get("/api/exemplars/1/labels.png?k=3")
        assert r.status_code == 404 and "not made yet" in r.json()["detail"]
        generate = client.post("/api/jobs", json={"exemplar_id": 1, **SMALL}).json()
        first = client.post("/api/exemplars/1/labels?k=3").json()
        assert first["url"] == "/api/exemplars/1/labels.png?k=3&method=color"
        assert first["job"]["kind"] == "labels" and first["job"]["state"] == "queued"
        # asked again (another tab, a reload): the same job, not a second one
        assert client.post("/api/exemplars/1/labels?k=3").json()["job"]["id"] == first["job"]["id"]
        other = client.post("/api/exemplars/1/labels?k=4").json()["job"]
        positions = {job["id"]: job["queue_position"] for job in client.get("/api/jobs").json()}
        assert positions[first["job"]["id"]] == 0 and positions[other["id"]] == 1
        assert positions[generate["id"]] == 2  # label maps take seconds: they go first
        assert client.delete(f"/api/jobs/{other['id']}").json()["state"] == "cancelled"
        assert client.post("/api/exemplars/1/labels?k=9").status_code == 400
        assert client.post("/api/exemplars/999/labels?k=3").status_code == 404
        # another site cannot start one: a POST from a foreign Origin is refused
        r = client.post("/api/exemplars/1/labels?k=5", headers={"origin": "http://evil.example"})
        assert r.status_code == 403
    with TestClient(create_app(Library(library.path))) as client:
        job = client.post("/api/exemplars/1/labels?k=3").json()["job"]
        assert _wait(client, job["id"], timeout=120)["state"] == "done"
        assert client.post("/api/exemplars/1/labels?k=3").json()["job"] is None  # made once
        picture = client.get("/api/exemplars/1/labels.png?k=3")
        assert picture.status_code == 200
        from barkgen.io import decode_image

        colours = np.unique(decode_image(picture.content).reshape(-1, 3), axis=0)
        assert len(colours) == 3


def test_the_job_queue_is_kept_in_the_library_across_restarts(library):
    """Waiting jobs wait again after a restart, in their order (label jobs first) and with
    their painted labels; a job that was running is failed, visibly; then they run."""
    from barkgen.web.jobs import INTERRUPTED, JobManager, spec_from_json, spec_to_json

    with TestClient(create_app(library, run_jobs=False)) as client:
        first = client.post("/api/jobs", json={"exemplar_id": 1, **SMALL, "seed": 1}).json()["id"]
        second = client.post("/api/jobs", json={"exemplar_id": 1, **SMALL, "seed": 2}).json()["id"]
        labels = client.post("/api/exemplars/1/labels?k=2").json()["job"]["id"]
        gone = client.post("/api/jobs", json={"exemplar_id": 1, **SMALL, "seed": 3}).json()["id"]
        client.delete(f"/api/jobs/{gone}")
        order = [job["id"] for job in client.get("/api/jobs").json()]
    # a server killed while a job ran left it "running" in the library
    record = next(r for r in library.jobs.saved() if r["id"] == first)
    library.jobs.save({**record, "state": "running", "started": time.time()})
    manager = JobManager(Library(library.path))
    assert manager.snapshot(first)["state"] == "failed" and manager.snapshot(first)["error"] == INTERRUPTED
    assert manager.snapshot(gone)["state"] == "cancelled"
    assert [manager.snapshot(i)["queue_position"] for i in (labels, second)] == [0, 1]
    assert order[:3] == [labels, first, second]  # the list follows the queue
    newer = manager.submit(1, {"seed": 9}, {})  # a job the next server cannot run (no spec)
    assert newer.order > max(manager.snapshot(i)["number"] for i in (first, second, labels, gone))
    # a spec round-trips exactly (a painted level is an array, the label map PNG bytes)
    painted = (np.arange(12, dtype=np.uint8).reshape(3, 4), b"\x89PNG...")
    spec = {
        "source": "a",
        "set_name": "b",
        "options": {"size": (3, 4), "k": 2},
        "labels_in": painted[1],
        "resume": (1, painted[0]),
    }
    back = spec_from_json(json.loads(json.dumps(spec_to_json(spec))))
    assert back["options"]["size"] == (3, 4) and back["labels_in"] == painted[1]
    assert back["resume"][0] == 1 and np.array_equal(back["resume"][1], painted[0])
    assert back["resume"][1].dtype == np.uint8
    with TestClient(create_app(Library(library.path))) as client:
        for job_id in (labels, second):
            assert _wait(client, job_id)["state"] == "done", job_id
        assert client.get(f"/api/jobs/{first}").json()["error"] == INTERRUPTED
        # a kept job that cannot run fails in one line, and the queue goes on
        broken = _wait(client, newer.id)
        assert broken["state"] == "failed" and "cannot be run" in broken["error"]
        after = client.post("/api/jobs", json={"exemplar_id": 1, **SMALL, "seed": 4}).json()["id"]
        assert _wait(client, after)["state"] == "done"


def test_painted_labels_are_checked_then_continued(client):
    exemplar_id = client.post("/api/exemplars", files={"file": ("a.png", _photo_png(seed=5))}).json()["id"]
    job = _wait(client, client.post("/api/jobs", json={"exemplar_id": exemplar_id, **SMALL, "seed": 7}).json()["id"])
    result = client.get(f"/api/results/{job['result_id']}").json()
    level = next(lv for lv in result["levels"] if lv["level"] == 1)
    coloured = client.get(level["url"])
    from barkgen.io import decode_image

    painted = decode_image(coloured.content).copy()
    palette = np.array(result["palette"], np.uint8)
    assert {tuple(c) for c in painted.reshape(-1, 3)} <= {tuple(c) for c in palette}

    def request(image, **changes):
        url = "data:image/png;base64," + base64.b64encode(encode_png(image)).decode()
        body = {
            "exemplar_id": exemplar_id,
            **SMALL,
            "seed": 7,
            "resume": {"result_id": result["id"], "level": 1, "labels": url},
        }
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


def test_route_functions_answer_without_a_server(library):
    """The routes' plain functions take the app's state and raise barkgen's errors: no HTTP."""
    from barkgen.errors import ImageTooLargeError, InvalidInputError
    from barkgen.library import NotFoundError
    from barkgen.web.jobs import JobManager
    from barkgen.web.routes_exemplars import coloured_labels, exemplar_details, store_upload
    from barkgen.web.routes_jobs import JobRequest, job_snapshot, start_job, stop_job
    from barkgen.web.state import AppState

    state = AppState(library, JobManager(library), WebLimits(max_upload_bytes=1024**2))
    added = store_upload(state, _photo_png(seed=11), "../../tmp/oak.png", species="oak")
    assert added["existing"] is False
    assert store_upload(state, _photo_png(seed=11), "again.png") == {"id": added["id"], "existing": True}
    # ten uploads of one new photo at once: one adds it, nine are told it was there
    from concurrent.futures import ThreadPoolExecutor

    photo = _photo_png(seed=12)
    with ThreadPoolExecutor(10) as pool:
        answers = list(pool.map(lambda i: store_upload(state, photo, f"same{i}.png"), range(10)))
    assert sorted(a["existing"] for a in answers) == [False] + [True] * 9
    assert len({a["id"] for a in answers}) == 1
    with pytest.raises(ImageTooLargeError, match="1 MB"):
        store_upload(state, bytes(1024**2 + 1), "big.png")
    details = exemplar_details(state, added["id"])
    assert details["name"] == "oak" and details["species"] == "oak" and details["results"] == []
    assert details["photo_url"] == f"/api/exemplars/{added['id']}/photo"
    with pytest.raises(InvalidInputError, match="between 2 and 8"):
        coloured_labels(state, added["id"], 9)
    # the queue is not running: the job waits, and is cancelled while it waits
    job = start_job(state, JobRequest(exemplar_id=added["id"], **SMALL, seed=5))
    snapshot = job_snapshot(state, job["id"])
    assert snapshot["state"] == "queued" and snapshot["params"]["seed"] == 5
    assert snapshot["params"]["size"] == [96, 96] and snapshot["params"]["resumed_from"] is None
    assert stop_job(state, job["id"])["state"] == "cancelled"
    with pytest.raises(InvalidInputError, match="4096"):
        start_job(state, JobRequest(exemplar_id=added["id"], **{**SMALL, "size": "9000x100"}))
    with pytest.raises(InvalidInputError, match="material set"):  # GenerateOptions' own rule
        start_job(state, JobRequest(exemplar_id=added["id"], **SMALL, relief=2.0))
    with pytest.raises(ValueError, match="less than or equal to 16"):  # the range, in the schema
        JobRequest(exemplar_id=added["id"], **{**SMALL, "k": 99})
    with pytest.raises(NotFoundError):
        start_job(state, JobRequest(exemplar_id=999, **SMALL))
    with pytest.raises(NotFoundError, match="no job nope"):
        job_snapshot(state, "nope")


@pytest.mark.parametrize("kind", ["generate", "labels"])
def test_ctrl_c_stops_the_server_with_a_job_and_its_event_stream_open(tmp_path, kind):
    """`barkgen serve` stops at once on Ctrl-C even while a page follows a running job, a
    generate job or the label map of a large photo (that one ran inside the server and held
    a Ctrl-C for minutes)."""
    import signal
    import socket
    import subprocess
    import sys

    import httpx

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    log = tmp_path / "serve.log"
    with open(log, "w") as out:
        process = subprocess.Popen(
            [sys.executable, "-m", "barkgen", "serve", "--port", str(port), "--library", str(tmp_path / "lib")],
            stdout=out,
            stderr=subprocess.STDOUT,
        )
    try:
        base = f"http://127.0.0.1:{port}"
        deadline = time.monotonic() + 60
        while "running at" not in log.read_text():
            assert process.poll() is None and time.monotonic() < deadline, log.read_text()
            time.sleep(0.1)
        if kind == "generate":
            job = httpx.post(f"{base}/api/jobs", json={"exemplar_id": 1, "size": "2048x2048", "seed": 1}).json()
            waiting = httpx.post(f"{base}/api/jobs", json={"exemplar_id": 1, **SMALL, "seed": 2}).json()
        else:  # a 6 MP photo: its label map takes seconds
            big = httpx.post(
                f"{base}/api/exemplars", files={"file": ("big.png", _photo_png(2400, seed=8))}, timeout=60
            ).json()["id"]
            job = httpx.post(f"{base}/api/exemplars/{big}/labels?k=5").json()["job"]
        lines: list[str] = []

        def follow() -> None:
            try:
                with httpx.stream("GET", f"{base}/api/jobs/{job['id']}/events", timeout=None) as stream:
                    for line in stream.iter_lines():
                        lines.append(line)
            except httpx.HTTPError:
                pass

        reader = threading.Thread(target=follow, daemon=True)
        reader.start()
        while not any('"running"' in line for line in lines):
            assert time.monotonic() < deadline, lines
            time.sleep(0.1)
        process.send_signal(signal.SIGINT)
        # Ctrl-C is how a server stops: not an error. It stops without finishing the running
        # job (said interrupted below, by the next server); how fast: bench_abuse.py's case 9
        assert process.wait(timeout=120) == 0
        assert "server stopped" in log.read_text() and "error" not in log.read_text()
        # the worker process went with it
        out = subprocess.run(["pgrep", "-f", f"barkgen serve --port {port}"], capture_output=True, text=True)
        assert out.stdout.strip() == ""
    finally:
        if process.poll() is None:
            process.kill()
    # the queue outlives the server: the next one says the running job was interrupted, and
    # the job that waited waits again (they answered 404 after a restart)
    from barkgen.web.jobs import INTERRUPTED

    with TestClient(create_app(Library(tmp_path / "lib"), run_jobs=False)) as client:
        again = client.get(f"/api/jobs/{job['id']}").json()
        assert again["state"] == "failed" and again["error"] == INTERRUPTED, again
        if kind == "generate":
            assert client.get(f"/api/jobs/{waiting['id']}").json()["state"] == "queued"


def test_numbers_json_cannot_hold_are_a_422_not_a_500(client):
    """A NaN seed, an exemplar id of 1e400, a 5000-digit size: one clear answer each (the
    validation error used to echo the NaN, which JSON cannot hold: a 500 and a traceback)."""
    for body, status, word in (
        ('{"exemplar_id": 1e400}', 422, "finite"),
        ('{"exemplar_id": 1, "seed": NaN}', 422, "finite"),
        ('{"exemplar_id": 1, "size": "1x' + "9" * 5000 + '"}', 400, "invalid size"),
        ('{"exemplar_id": 1, "size": "1x99999999"}', 400, "megapixels"),
    ):
        r = client.post("/api/jobs", content=body, headers={"content-type": "application/json"})
        assert r.status_code == status and word in r.text and len(r.text) < 400, (body[:40], r.text[:200])


def _set_zip(size: int = 96, **extra: bytes) -> tuple[bytes, np.ndarray]:
    """A zipped scanned set (ambientCG names, in a folder as Poly Haven zips them) and its
    roughness, whose values are all distinct multiples of 257 (16-bit)."""
    rng = np.random.default_rng(3)
    roughness = (rng.permutation(size * size).reshape(size, size) % 255 + 1).astype(np.uint16) * 257
    normals = np.dstack([rng.normal(0, 0.2, (size, size, 2)), np.ones((size, size))])
    normals /= np.linalg.norm(normals, axis=2, keepdims=True)
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        archive.writestr("Bark099_1K-PNG/Bark099_1K-PNG_Color.png", _photo_png(size, seed=9))
        archive.writestr(
            "Bark099_1K-PNG/Bark099_1K-PNG_NormalGL.png", encode_png(np.round((normals + 1) * 127.5).astype(np.uint8))
        )
        archive.writestr("Bark099_1K-PNG/Bark099_1K-PNG_Roughness.png", encode_png(roughness))
        archive.writestr("Bark099_1K-PNG/Bark099.usda", b"#usda 1.0")  # not a map: left out
        archive.writestr("__MACOSX/Bark099_1K-PNG/._Bark099_1K-PNG_Color.png", b"\0\5\26\7")
        for name, data in extra.items():
            archive.writestr(name, data)
    return buffer.getvalue(), roughness


def test_a_zipped_scanned_set_is_an_exemplar_whose_maps_make_the_material(client, library, tmp_path):
    data, roughness = _set_zip()
    r = client.post("/api/exemplars", files={"file": ("Bark099_1K-PNG.zip", data)}, data={"licence": "CC0"})
    assert r.status_code == 201, r.text
    exemplar = client.get(f"/api/exemplars/{r.json()['id']}").json()
    assert exemplar["name"] == "Bark099" and exemplar["licence"] == "CC0"
    assert exemplar["maps"] == ["normal_gl", "roughness"] and exemplar["source"] == "uploaded set"
    assert sorted(library.set_files(exemplar["id"])) == [
        f"Bark099_1K-PNG_{m}.png" for m in ("Color", "NormalGL", "Roughness")
    ]
    again = client.post("/api/exemplars", files={"file": ("copy.zip", data)})
    assert again.json() == {"id": exemplar["id"], "existing": True}
    # a result with material: the set's own roughness, carried (its values, not an estimate)
    body = {"exemplar_id": exemplar["id"], "size": "128x128", "k": 2, "tile": True, "material": True, "seed": 4}
    job = _wait(client, client.post("/api/jobs", json=body).json()["id"])
    assert job["state"] == "done", job
    result = client.get(f"/api/results/{job['result_id']}").json()
    from scipy import ndimage

    from barkgen.io import decode_image, read_reference
    from barkgen.synth import piece_borders

    name = next(n for n in result["files"] if n.endswith("_Roughness.png"))
    out = decode_image(client.get(result["files"][name]).content)[..., 0]
    assert out.shape == (128, 128)
    # exact where the reference map runs on (>= 8 px inside its pieces: the seams are blended)
    reference = tmp_path / "reference.png"
    reference.write_bytes(client.get(result["files"]["reference.png"]).content)
    references, _ = read_reference(reference)
    carried = roughness[references[..., 0] % 96, references[..., 1] % 96]
    carried = carried if out.dtype == np.uint16 else carried // 257
    inside = np.pad(
        ~piece_borders(references, (96, 96), Canvas(references.shape[:2], tile=True)), 9, mode="wrap"
    )  # tiled: across the edges
    inside = ndimage.distance_transform_edt(inside)[9:-9, 9:-9] >= 8
    assert inside.mean() > 0.1 and np.mean(out[inside] == carried[inside]) > 0.95
    # bad sets: one line each, 400, nothing added
    count = len(client.get("/api/exemplars").json())
    for payload, said in ((b"PK\x03\x04 not really a zip", "not a zip"),):
        r = client.post("/api/exemplars", files={"file": ("set.zip", payload)})
        assert r.status_code == 400 and said in r.json()["detail"], r.text
        assert "\n" not in r.json()["detail"]
    assert len(client.get("/api/exemplars").json()) == count
    # files it cannot place: one line each, the set made from the others (here: the same set)
    for extra, said in (
        ({"Bark099_Sheen.png": _photo_png(96)}, "set.zip/Bark099_Sheen.png: left out"),
        ({"Other_Roughness.png": _photo_png(96)}, "set.zip/Other_Roughness.png: left out"),
    ):
        r = client.post("/api/exemplars", files={"file": ("set.zip", _set_zip(**extra)[0])})
        assert r.json()["id"] == exemplar["id"] and r.json()["existing"] is True, r.text
        assert len(r.json()["left_out"]) == 1 and said in r.json()["left_out"][0], r.text
    # a map of another size is resampled: another set of its own
    r = client.post("/api/exemplars", files={"file": ("set.zip", _set_zip(**{"Bark099_AO.png": _photo_png(64)})[0])})
    assert r.status_code == 201 and r.json()["id"] != exemplar["id"] and "left_out" not in r.json()
    assert client.get(f"/api/exemplars/{r.json()['id']}").json()["maps"] == ["ao", "normal_gl", "roughness"]


def test_the_form_has_the_clis_defaults_and_every_web_option(client):
    """``/api/options``: one set of defaults (GenerateOptions', the CLI's) with the help, choices
    and ranges the form shows, the server's largest side, the k range and the set layouts."""
    from barkgen._shared.options import option_fields
    from barkgen.pipeline import GenerateOptions

    answer = client.get("/api/options").json()
    fields = {f["name"]: f for f in answer["fields"]}
    for f in option_fields(GenerateOptions, "cli"):
        if f.name in fields and f.name not in ("seed", "material"):  # (WEB_DEFAULTS: test_web_names.py)
            assert fields[f.name]["default"] == f.default_text, f.name
    for name in ("size", "k", "method", "strategy", "relief", "tile", "material", "structure", "model", "seed"):
        assert name in fields, name
    assert fields["equalize_light"]["default"] == 1.0 and fields["width_m"]["default"] is None
    # a set's width outside the option's range is refused in one line, before any job
    bad = client.post("/api/jobs", json={"exemplar_id": 1, **SMALL, "material": True, "width_m": -1})
    assert bad.status_code == 422 and bad.json()["detail"][0]["loc"][-1] == "width_m"
    assert fields["seed"]["default"] is None  # the page rolls one
    assert fields["material"]["default"] is True  # the material set, as the quickstart makes it
    assert fields["structure"]["choices"] == ["labels", "cracks"] and fields["model"]["choices"] == [
        "patches",
        "bilayer",
    ]
    assert answer["k_range"] == [2, 8] and "gltf" in answer["presets"] and answer["max_output_side"] >= 2048


def test_cracks_and_bilayer_jobs_texton_labels_glb_and_a_zip_named_after_the_photo(client, library):
    """A photo of cracks gets a crack job and a bi-layer job from the API; each result says what
    it is. Texton label maps are their own analysis. A result with material maps has its trunk
    as a glb, and the zip is named after the photo, its set too, with the licence given at
    upload in README.txt."""
    from conftest import crack_photo_file

    mud = crack_photo_file(256, 0, cell=32).read_bytes()  # a drawn crack network, as of dried mud
    r = client.post(
        "/api/exemplars",
        files={"file": ("dried mud.png", mud)},
        data={"name": "Dried mud", "licence": "CC0 (drawn by the tests)"},
    )
    assert r.status_code == 201, r.text
    ex = r.json()["id"]
    kinds = client.get(f"/api/exemplars/{ex}/kinds").json()
    assert kinds["cracks"]["suits"] and "crack branches found" in kinds["cracks"]["why"] and kinds["bilayer"]["suits"]
    blank = client.post("/api/exemplars", files={"file": ("flat.png", encode_png(np.full((96, 96, 3), 120, np.uint8)))})
    flat = client.get(f"/api/exemplars/{blank.json()['id']}/kinds").json()
    assert not flat["cracks"]["suits"] and "no crack" in flat["cracks"]["why"]

    texton = client.post(f"/api/exemplars/{ex}/labels?k=3&method=texton").json()
    assert texton["method"] == "texton" and "method=texton" in texton["url"]
    assert _wait(client, texton["job"]["id"])["state"] == "done"
    assert client.get(texton["url"]).status_code == 200
    assert client.post(f"/api/exemplars/{ex}/labels?k=3&method=sobel").status_code == 400

    jobs = {}
    for kind in ({"structure": "cracks", "material": True, "preset": "gltf"}, {"model": "bilayer"}):
        body = {"exemplar_id": ex, **SMALL, "size": "96x80", "tile": True, "seed": 5, **kind}
        r = client.post("/api/jobs", json=body)
        assert r.status_code == 201, r.text
        job = _wait(client, r.json()["id"])
        assert job["state"] == "done", job
        jobs[next(iter(kind.values()))] = job["result_id"]
    cracks = client.get(f"/api/results/{jobs['cracks']}").json()
    assert cracks["params"]["structure"] == "cracks" and cracks["params"]["preset"] == "gltf"
    assert client.get(f"/api/results/{jobs['bilayer']}").json()["params"]["model"] == "bilayer"
    glb = client.get(f"/api/results/{jobs['cracks']}/files/trunk.glb")
    assert glb.status_code == 200 and glb.content[:4] == b"glTF"
    r = client.get(f"/api/results/{jobs['cracks']}/download")
    assert 'filename="Dried-mud_seed5_96x80.zip"' in r.headers["content-disposition"]
    archive = zipfile.ZipFile(io.BytesIO(r.content))
    readme = archive.read("Dried-mud_seed5_96x80_README.txt").decode()
    assert "Photo licence: CC0 (drawn by the tests)" in readme and "Dried-mud_seed5_96x80_trunk.glb" in readme
    assert all(n.startswith("Dried-mud_seed5_96x80") for n in archive.namelist()), archive.namelist()
    # k beyond the pages' range, an unknown kind: one line, 4xx
    r = client.post("/api/jobs", json={"exemplar_id": ex, **SMALL, "k": 9})
    assert r.status_code in (400, 422) and "k" in r.text
    r = client.post("/api/jobs", json={"exemplar_id": ex, **SMALL, "structure": "veins"})
    assert r.status_code == 422
