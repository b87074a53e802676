"""The web app's crack view over the JSON API (sibbing2010 §6, Fig. 8): a photo's crack network
as structure JSON (cached), edits of it answered as new structures, a photo rectified from four
corners into a new exemplar, and a cracks job that learns from the edited network, with one-line
4xx answers to bad input."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import crack_photo_file
from fastapi.testclient import TestClient
from test_web_api import _wait

from barkgen.branching import Structure, delete_branch
from barkgen.io import decode_image, encode_png
from barkgen.library import Library
from barkgen.web import create_app

JOB = {"size": "96x80", "k": 2, "tile": True, "material": False, "seed": 5, "structure": "cracks"}


def _one_line(r, *statuses: int) -> str:
    assert r.status_code in statuses, (r.status_code, r.text)
    detail = r.json()["detail"]
    if isinstance(detail, list):  # pydantic's 422: a list of {loc, msg}
        detail = "; ".join(d["msg"] for d in detail)
    assert detail and "\n" not in detail and "Traceback" not in detail, detail
    return detail


@pytest.fixture()
def library(tmp_path):
    return Library(tmp_path / "lib")


@pytest.fixture()
def client(library):
    with TestClient(create_app(library)) as c:
        yield c


@pytest.fixture()
def mud(client) -> int:
    data = crack_photo_file(256, 0, cell=32).read_bytes()  # a drawn crack network, as of dried mud
    r = client.post("/api/exemplars", files={"file": ("mud.png", data)}, data={"name": "Dried mud"})
    assert r.status_code == 201, r.text
    return r.json()["id"]


def _middle(structure: dict, index: int) -> list[float]:
    points = structure["branches"][index]["points"]
    return points[len(points) // 2][:2]


def test_the_crack_network_is_served_cached_and_edited(client, library, mud):
    r = client.get(f"/api/exemplars/{mud}/cracks")
    assert r.status_code == 200, r.text
    data = r.json()
    assert data["size"] == [256, 256] and data["version"] == 1 and len(data["branches"]) > 50
    assert library.analysis(mud, "cracks", {"version": 1}) is not None  # cached with the photo
    assert client.get(f"/api/exemplars/{mud}/cracks").json() == data
    n = len(data["branches"])

    # delete: a click on a branch removes it and its sub-branches
    r = client.post(
        f"/api/exemplars/{mud}/cracks/edit", json={"structure": data, "tool": "delete", "points": [_middle(data, 1)]}
    )
    assert r.status_code == 200, r.text
    deleted = r.json()
    assert deleted["picked"] == 1 and deleted["branch"] is None
    expected = delete_branch(Structure.from_dict(data), 1)
    assert deleted["structure"] == expected.to_dict() and len(deleted["structure"]["branches"]) < n - 1

    # extend: a click near a branch's end, then the target; the end reaches it
    tree = deleted["structure"]
    first = tree["branches"][0]["points"]
    end, before = first[-1][:2], first[-5][:2]
    target = [min(max(2 * end[0] - before[0], 1), 255), min(max(2 * end[1] - before[1], 1), 255)]
    r = client.post(
        f"/api/exemplars/{mud}/cracks/edit", json={"structure": tree, "tool": "extend", "points": [end, target]}
    )
    assert r.status_code == 200, r.text
    extended = r.json()
    grown = extended["structure"]["branches"][extended["branch"]]["points"]
    assert np.allclose(grown[-1][:2], target, atol=1e-3)
    assert grown[: len(first)] == first  # the branch's vertices kept

    # furcation: a click on a branch, then the target: a new last branch starting on it
    r = client.post(
        f"/api/exemplars/{mud}/cracks/edit",
        json={"structure": extended["structure"], "tool": "furcation", "points": [_middle(tree, 0), [128, 128]]},
    )
    assert r.status_code == 200, r.text
    forked = r.json()
    child = forked["structure"]["branches"][-1]
    assert forked["branch"] == len(forked["structure"]["branches"]) - 1 and child["parent"] == forked["picked"]
    assert np.allclose(child["points"][-1][:2], [128, 128])
    Structure.from_dict(forked["structure"])  # still a valid structure


def test_bad_edits_and_unknown_photos_are_one_line(client, mud):
    data = client.get(f"/api/exemplars/{mud}/cracks").json()
    url = f"/api/exemplars/{mud}/cracks/edit"
    far = {"structure": data, "tool": "delete", "points": [[0, 0]], "tolerance": 0.01}
    assert "no branch within" in _one_line(client.post(url, json=far), 400)
    small = {**data, "size": [128, 128]}
    body = {"structure": small, "tool": "delete", "points": [_middle(data, 1)]}
    assert "not the photo's 256x256" in _one_line(client.post(url, json=body), 400)
    body = {"structure": {**data, "branches": []}, "tool": "delete", "points": [[1, 1]]}
    assert "empty" in _one_line(client.post(url, json=body), 400)
    body = {"structure": data, "tool": "extend", "points": [_middle(data, 1)]}
    assert "2 point(s)" in _one_line(client.post(url, json=body), 400)
    body = {"structure": data, "tool": "extend", "points": [data["branches"][0]["points"][-1][:2], [900, 10]]}
    assert "outside the 256x256" in _one_line(client.post(url, json=body), 400)
    body = {"structure": data, "tool": "paint", "points": [[1, 1]]}
    _one_line(client.post(url, json=body), 422)
    assert client.get("/api/exemplars/999/cracks").status_code == 404
    assert client.post("/api/exemplars/999/cracks/edit", json={**far, "tolerance": 16}).status_code == 404
    # a photo without cracks: one line saying so
    flat = client.post("/api/exemplars", files={"file": ("flat.png", encode_png(np.full((96, 96, 3), 120, np.uint8)))})
    assert "no cracks found" in _one_line(client.get(f"/api/exemplars/{flat.json()['id']}/cracks"), 400)


def _photographed_board() -> tuple[bytes, list[list[float]]]:
    import cv2

    y, x = np.mgrid[0:192, 0:192]
    board = ((x // 24 + y // 24) % 2 * 200 + 28).astype(np.uint8)
    board = np.stack([board, board // 2 + 60, board], -1)
    plane = np.array([[0, 0], [191, 0], [191, 191], [0, 191]], np.float32)
    seen = np.array([[40, 30], [250, 62], [236, 268], [52, 230]], np.float32)
    photo = cv2.warpPerspective(board, cv2.getPerspectiveTransform(plane, seen), (300, 300), borderValue=(90, 120, 60))
    return encode_png(photo), seen.tolist()


def test_rectify_adds_the_rectified_photo_as_a_new_exemplar(client, library):
    data, corners = _photographed_board()
    r = client.post("/api/exemplars", files={"file": ("board.png", data)}, data={"name": "Board", "licence": "CC0"})
    ex = r.json()["id"]
    r = client.post(f"/api/exemplars/{ex}/rectify", json={"corners": corners})
    assert r.status_code == 201, r.text
    new = r.json()
    assert new["existing"] is False and new["id"] != ex
    record = client.get(f"/api/exemplars/{new['id']}").json()
    assert record["name"] == "Board (rectified)" and record["licence"] == "CC0"
    assert record["source"] == "rectified from Board"
    assert abs(record["width"] - 192) <= 12 and abs(record["height"] - 192) <= 12
    # the rectified photo's cells are square again: its boundaries along a row are evenly spaced
    photo = decode_image(library.photo_bytes(new["id"]))[..., 0].astype(float) - 128
    row = photo[photo.shape[0] // 2 + 12]
    crossings = np.nonzero((row[:-1] >= 0) != (row[1:] >= 0))[0]
    assert len(crossings) == 7 and np.ptp(np.diff(crossings)) <= 2, crossings
    # the same corners again: that exemplar; a name of one's own
    again = client.post(f"/api/exemplars/{ex}/rectify", json={"corners": corners})
    assert again.status_code == 200 and again.json() == {"id": new["id"], "existing": True}
    named = client.post(f"/api/exemplars/{ex}/rectify", json={"corners": corners[1:] + corners[:1], "name": "Turned"})
    assert named.status_code == 201 and client.get(f"/api/exemplars/{named.json()['id']}").json()["name"] == "Turned"
    # bad corners: one line each
    bow_tie = [corners[0], corners[2], corners[1], corners[3]]
    assert "convex" in _one_line(client.post(f"/api/exemplars/{ex}/rectify", json={"corners": bow_tie}), 400)
    outside = [[10, 10], [400, 10], [290, 290], [10, 290]]
    assert "outside" in _one_line(client.post(f"/api/exemplars/{ex}/rectify", json={"corners": outside}), 400)
    _one_line(client.post(f"/api/exemplars/{ex}/rectify", json={"corners": corners[:3]}), 422)
    assert client.post("/api/exemplars/999/rectify", json={"corners": corners}).status_code == 404


def test_a_cracks_job_learns_from_the_edited_network(client, library, mud):
    """Deleting most branches in the crack view: the job's model learns from the few left (its
    report says so), the photo's crack label map is the edited network's raster, and the new
    network grown from it differs from the one grown from the whole network."""
    data = client.get(f"/api/exemplars/{mud}/cracks").json()
    pruned = Structure.from_dict(data)
    while len(pruned.branches) > 12:
        pruned = delete_branch(pruned, len(pruned.branches) - 1)
    results = {}
    for name, extra in (("whole", {}), ("edited", {"crack_structure": pruned.to_dict()})):
        r = client.post("/api/jobs", json={"exemplar_id": mud, **JOB, **extra})
        assert r.status_code == 201, r.text
        job = _wait(client, r.json()["id"], timeout=240)
        assert job["state"] == "done", job
        results[name] = job["result_id"]
    reports = {k: client.get(f"/api/results/{v}/files/report.json").json() for k, v in results.items()}
    whole, edited = reports["whole"]["crack_model"], reports["edited"]["crack_model"]
    assert whole["branches"] == len(data["branches"]) and edited["branches"] == 12
    assert edited["source_length"] < 0.5 * whole["source_length"]
    assert edited["furcations"] < whole["furcations"]
    # the photo's crack map is the edited network's raster (far less crack), the grown one differs
    fraction_in = {k: rep["label_fractions_in"]["0"] for k, rep in reports.items()}
    assert fraction_in["edited"] < 0.5 * fraction_in["whole"], fraction_in
    outs = {k: decode_image(client.get(f"/api/results/{v}/files/labels_out.png").content) for k, v in results.items()}
    assert not np.array_equal(outs["whole"], outs["edited"])
    params = client.get(f"/api/results/{results['edited']}").json()["params"]
    assert params["crack_structure"] == {"edited": True, "branches": 12}
    assert "crack_structure" not in client.get(f"/api/results/{results['whole']}").json()["params"]

    # bad edited networks: one line, 4xx, no job
    jobs = len(client.get("/api/jobs").json())
    bad = [
        ({**JOB, "structure": "labels", "crack_structure": data}, "structure 'cracks' only"),
        ({**JOB, "crack_structure": {**data, "size": [64, 64]}}, "not the photo's 256x256"),
        ({**JOB, "crack_structure": {**data, "version": 7}}, "version must be 1"),
        ({**JOB, "crack_structure": {**data, "branches": [{"points": [[1, 1, 1]]}]}}, "at least two"),
    ]
    for body, message in bad:
        assert message in _one_line(client.post("/api/jobs", json={"exemplar_id": mud, **body}), 400)
    _one_line(client.post("/api/jobs", json={"exemplar_id": mud, **JOB, "crack_structure": [1, 2]}), 422)
    assert len(client.get("/api/jobs").json()) == jobs
