"""The web app's relief editor on the API (wang2003 §3.3): edits spread to self-similar places,
undo from the kept heights, Save as a job, and the saved edits replayed by the CLI to the same
bytes."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import run
from fastapi.testclient import TestClient
from test_web_api import _photo_png, _wait

from barkgen.io import decode_image
from barkgen.library import Library
from barkgen.material import HeightEditor, parse_edits
from barkgen.web import create_app

SETTINGS = {"size": "128x128", "k": 2, "tile": True, "material": True, "seed": 3}
#: a stroke of five edits, as the page sends them (raise 2 px, radius 3)
STROKE = [{"x": 20 + 6 * i, "y": 40, "delta": 2.0, "radius": 3} for i in range(5)]


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    folder = tmp_path_factory.mktemp("relief")
    photo = folder / "photo.png"
    photo.write_bytes(_photo_png(seed=2))
    with TestClient(create_app(Library(folder / "lib"))) as client:
        exemplar = client.post("/api/exemplars", files={"file": ("photo.png", photo.read_bytes())}).json()
        job = _wait(client, client.post("/api/jobs", json={"exemplar_id": exemplar["id"], **SETTINGS}).json()["id"])
        assert job["state"] == "done", job
        yield client, client.get(f"/api/results/{job['result_id']}").json(), photo, folder


def heights(client, result_id: int, edits: list[dict]) -> np.ndarray:
    answer = client.post(f"/api/results/{result_id}/relief", json={"edits": edits})
    assert answer.status_code == 200, answer.text
    w, h = (int(v) for v in answer.headers["X-Height-Size"].split("x"))
    return np.frombuffer(answer.content, "<f4").reshape(h, w)


def test_a_stroke_spreads_to_self_similar_places_and_undoes(served):
    client, result, _, _ = served
    base = heights(client, result["id"], [])
    edited = heights(client, result["id"], STROKE)
    change = edited - base
    # each edited pixel rises by at least its own edit's 2 px
    for edit in STROKE:
        assert change[edit["y"], edit["x"]] >= 2.0 - 1e-4
    # and the edits spread: pixels far from the stroke (more than 3 radii) rise too, where their
    # neighbourhood looks like an edited one, and only within the edited pixels' label
    far = np.ones(change.shape, bool)
    far[40 - 12 : 40 + 13, 20 - 12 : 44 + 13] = False
    risen = (change > 0.05) & far
    assert 0.01 < risen.mean() < 0.9
    labels = decode_image(client.get(result["files"]["labels_out.png"]).content)
    labels = labels[..., 0] if labels.ndim == 3 else labels
    edited_labels = {int(labels[e["y"], e["x"]]) for e in STROKE}
    assert set(np.unique(labels[change > 1e-6]).tolist()) <= edited_labels
    # what the page gets is HeightEditor's replay of the list on the base height
    texture = decode_image(client.get(result["files"]["texture.png"]).content)
    editor = HeightEditor(texture, base, labels, tile=True)
    assert np.array_equal(editor.apply(parse_edits({"version": 1, "edits": STROKE})), edited)
    # undo (the list without its last edit) and redo answer from the kept heights, the same
    undone = heights(client, result["id"], STROKE[:-1])
    assert np.array_equal(
        undone, HeightEditor(texture, base, labels, tile=True).apply(parse_edits({"version": 1, "edits": STROKE[:-1]}))
    )
    assert np.array_equal(heights(client, result["id"], STROKE), edited)
    assert np.array_equal(heights(client, result["id"], []), base)


def test_bad_edits_are_one_line(served):
    client, result, _, _ = served
    outside = client.post(f"/api/results/{result['id']}/relief", json={"edits": [{"x": 500, "y": 1, "delta": 1}]})
    assert outside.status_code == 400 and "outside the 128x128 result" in outside.json()["detail"]
    wrong = client.post(f"/api/results/{result['id']}/relief", json={"edits": [{"x": 1, "y": 1}]})
    assert wrong.status_code == 400 and "delta" in wrong.json()["detail"]
    assert client.post("/api/results/999/relief", json={"edits": []}).status_code == 404


def test_saved_edits_make_a_result_the_cli_replays_byte_for_byte(served, tmp_path):
    client, result, photo, _ = served
    body = {
        "exemplar_id": result["exemplar_id"],
        **SETTINGS,
        "relief_edits": {"result_id": result["id"], "edits": STROKE},
    }
    saved = _wait(client, client.post("/api/jobs", json=body).json()["id"])
    assert saved["state"] == "done", saved
    edited = client.get(f"/api/results/{saved['result_id']}").json()
    assert edited["parent_id"] == result["id"]
    assert edited["params"]["relief_from"] == {"result_id": result["id"], "edits": 5}
    document = json.loads(client.get(edited["files"]["edits.json"]).content)
    assert parse_edits(document) == parse_edits({"version": 1, "edits": STROKE})
    web = client.get(edited["maps"]["Displacement"]).content
    assert web != client.get(result["maps"]["Displacement"]).content
    # barkgen generate --material --edits: the same displacement, byte for byte
    edits_file = tmp_path / "edits.json"
    edits_file.write_text(json.dumps(document))
    out = tmp_path / "out"
    args = ["generate", str(photo), "-o", str(out), "--size", "128x128", "--k", "2", "--tile", "--material"]
    replay = run(*args, "--seed", "3", "--edits", str(edits_file), "-q")
    assert replay.returncode == 0, replay.stderr
    name = next(p for p in out.glob("*_Displacement.png"))
    assert name.read_bytes() == web
    normals = next(n for n in edited["files"] if n.endswith("_NormalGL.png"))
    assert next(out.glob("*_NormalGL.png")).read_bytes() == client.get(edited["files"][normals]).content
    # sculpting the saved result again and saving: its edits first, then the new ones
    more = [{"x": 100, "y": 90, "delta": -1.5, "radius": 2}]
    again = {**body, "relief_edits": {"result_id": edited["id"], "edits": more}}
    twice = _wait(client, client.post("/api/jobs", json=again).json()["id"])
    document = json.loads(
        client.get(client.get(f"/api/results/{twice['result_id']}").json()["files"]["edits.json"]).content
    )
    replayed = parse_edits(document)
    assert replayed[:5] == parse_edits({"version": 1, "edits": STROKE}) and replayed[5].delta == -1.5
    # a save without material maps, or with no edits, is refused in one line
    refused = client.post("/api/jobs", json={**body, "material": False})
    assert refused.status_code == 400 and "material" in refused.json()["detail"]
    refused = client.post("/api/jobs", json={**body, "relief_edits": {"result_id": result["id"], "edits": []}})
    assert refused.status_code == 400 and "no relief edit" in refused.json()["detail"]
