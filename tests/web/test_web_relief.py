"""The web app's relief editor on the API (wang2003 §3.3): edits spread to self-similar places,
undo from the kept heights, Save as a job with the depth and photo light the sliders chose, and
the saved edit list replayed by the CLI to the same bytes."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import run
from fastapi.testclient import TestClient
from test_web_api import _photo_png, _wait

from barkgen.io import decode_image, encode_png
from barkgen.library import Library
from barkgen.material import Boundary, EditList, HeightEditor, decode_illumination, parse_edit_list, parse_edits
from barkgen.material.illumination import relit
from barkgen.web import create_app

SETTINGS = {"size": "128x128", "k": 2, "tile": True, "material": True, "seed": 3}
#: a stroke of five edits, as the page sends them (raise 2 px, radius 3)
STROKE = [{"x": 20 + 6 * i, "y": 40, "delta": 2.0, "radius": 3} for i in range(5)]


def _trunk_photo() -> bytes:
    """Bark lit as round a trunk: brighter in the middle, darker to the sides (a broad light the
    run takes out and the Photo light slider puts back)."""
    bark = decode_image(_photo_png(seed=2)).astype(np.float64)
    falloff = 0.25 + 0.75 * np.sin(np.pi * np.arange(bark.shape[1]) / (bark.shape[1] - 1))
    return encode_png(np.clip(bark * falloff[None, :, None], 0, 255).astype(np.uint8))


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    folder = tmp_path_factory.mktemp("relief")
    photo = folder / "photo.png"
    photo.write_bytes(_trunk_photo())
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
    editor = HeightEditor(texture, base, labels, boundary=Boundary(True))
    assert np.array_equal(editor.apply(parse_edits({"version": 1, "edits": STROKE})), edited)
    # undo (the list without its last edit) and redo answer from the kept heights, the same
    undone = heights(client, result["id"], STROKE[:-1])
    assert np.array_equal(
        undone,
        HeightEditor(texture, base, labels, boundary=Boundary(True)).apply(
            parse_edits({"version": 1, "edits": STROKE[:-1]})
        ),
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


def _record(client, result: dict) -> dict:
    """A result's set's ``NAME.json``."""
    name = next(n for n in result["files"] if n.endswith("_Displacement.png"))[: -len("_Displacement.png")]
    return json.loads(client.get(result["files"][f"{name}.json"]).content)


def test_saved_edits_depth_and_light_make_a_result_the_cli_replays_byte_for_byte(served, tmp_path):
    """Save with a stroke and the sliders' depth (1.5x) and photo light (half of it taken out):
    edits.json holds all three, and ``barkgen generate --edits`` makes the same maps."""
    client, result, photo, _ = served
    saved_edits = {"result_id": result["id"], "edits": STROKE, "relief": 1.5, "light_equalization": 0.5}
    body = {"exemplar_id": result["exemplar_id"], **SETTINGS, "relief_edits": saved_edits}
    saved = _wait(client, client.post("/api/jobs", json=body).json()["id"])
    assert saved["state"] == "done", saved
    edited = client.get(f"/api/results/{saved['result_id']}").json()
    assert edited["parent_id"] == result["id"]
    assert edited["params"]["relief_from"] == {
        "result_id": result["id"],
        "edits": 5,
        "relief": 1.5,
        "light_equalization": 0.5,
    }
    document = json.loads(client.get(edited["files"]["edits.json"]).content)
    stroke = tuple(parse_edits({"version": 1, "edits": STROKE}))
    assert parse_edit_list(document) == EditList(stroke, 1.5, 0.5)
    assert _record(client, edited)["light_equalization"] == 0.5
    web = client.get(edited["maps"]["Displacement"]).content
    assert web != client.get(result["maps"]["Displacement"]).content
    # barkgen generate --material --edits: the same maps, byte for byte
    edits_file = tmp_path / "edits.json"
    edits_file.write_text(json.dumps(document))
    out = tmp_path / "out"
    args = ["generate", str(photo), "-o", str(out), "--size", "128x128", "--k", "2", "--tile", "--material"]
    replay = run(*args, "--seed", "3", "--edits", str(edits_file), "-q")
    assert replay.returncode == 0, replay.stderr
    for suffix in ("Displacement", "NormalGL", "Color", "AmbientOcclusion"):
        assert next(out.glob(f"*_{suffix}.png")).read_bytes() == client.get(edited["maps"][suffix]).content, suffix
    # under the same name: the photo's, the seed and the edits' tag (issue 66)
    assert edited["set_name"].startswith("photo_seed3-edit") and edited["set_name"].endswith("_128x128")
    assert next(out.glob("*_Color.png")).name == f"{edited['set_name']}_Color.png"
    cli_record = json.loads(next(p for p in out.glob("*.json") if p.name != "report.json").read_text())
    assert cli_record["displacement_depth_m"] == _record(client, edited)["displacement_depth_m"]
    # sculpting the saved result again and saving 2x deeper: its edits first, then the new ones
    # (their deltas in its run's heights: over its 1.5x), the depths multiplied, its light kept
    more = [{"x": 100, "y": 90, "delta": -1.5, "radius": 2}]
    again = {**body, "relief_edits": {"result_id": edited["id"], "edits": more, "relief": 2.0}}
    twice = _wait(client, client.post("/api/jobs", json=again).json()["id"])
    document = json.loads(
        client.get(client.get(f"/api/results/{twice['result_id']}").json()["files"]["edits.json"]).content
    )
    replayed = parse_edit_list(document)
    assert replayed.edits[:5] == stroke and replayed.edits[5].delta == -1.0
    assert (replayed.relief, replayed.light_equalization) == (3.0, 0.5)
    # a save without material maps, or with nothing to save, is refused in one line
    refused = client.post("/api/jobs", json={**body, "material": False})
    assert refused.status_code == 400 and "material" in refused.json()["detail"]
    refused = client.post("/api/jobs", json={**body, "relief_edits": {"result_id": result["id"], "edits": []}})
    assert refused.status_code == 400 and "no relief edit" in refused.json()["detail"]


def test_depth_and_light_alone_save_a_deeper_relit_set_and_bad_values_are_one_line(served):
    """Save with the sliders only: the set 2x as deep (its depth in metres too), a quarter of
    the photo's light out of its colour (the colour the page shows: the parent's times
    L^(1 - 0.25) in linear light); depths and lights out of range, and a light on a result
    that has no record of its photo's, are refused in one line."""
    client, result, _, _ = served
    light = np.frombuffer(client.get(f"/api/results/{result['id']}/illumination").content, "<f4").reshape(128, 128)
    illumination = decode_image(client.get(result["files"]["illumination.png"]).content)
    assert np.array_equal(light, decode_illumination(illumination)) and np.ptp(light) > 0
    saved_edits = {"result_id": result["id"], "edits": [], "relief": 2.0, "light_equalization": 0.25}
    body = {"exemplar_id": result["exemplar_id"], **SETTINGS, "relief_edits": saved_edits}
    saved = _wait(client, client.post("/api/jobs", json=body).json()["id"])
    assert saved["state"] == "done", saved
    adjusted = client.get(f"/api/results/{saved['result_id']}").json()
    before, after = _record(client, result), _record(client, adjusted)
    assert after["displacement_depth_m"] == pytest.approx(2 * before["displacement_depth_m"], rel=1e-5)
    assert after["displacement_depth_px"] == pytest.approx(2 * before["displacement_depth_px"], rel=1e-5)
    assert (before["light_equalization"], after["light_equalization"]) == (1.0, 0.25)
    assert adjusted["material"]["light_equalization"] == 0.25 and adjusted["material"]["illumination_url"]
    parent_colour = decode_image(client.get(result["maps"]["Color"]).content)
    relit_colour = decode_image(client.get(adjusted["maps"]["Color"]).content).astype(int)
    assert np.abs(relit_colour - relit(parent_colour, light, 0.75).astype(int)).max() <= 2
    assert np.abs(relit_colour - parent_colour.astype(int)).mean() > 1  # the light did change
    document = json.loads(client.get(adjusted["files"]["edits.json"]).content)
    assert document == {"version": 1, "edits": [], "relief": 2.0, "light_equalization": 0.25}
    for bad, words in (
        ({"relief": 5.0}, "the depth must be 0.25x to 4x the result's, not 5x"),
        ({"relief": 0.1}, "not 0.1x"),
        ({"light_equalization": 1.5}, "the photo light taken out must be 0 to 1, not 1.5"),
        ({"light_equalization": -0.1}, "not -0.1"),
    ):
        answer = client.post("/api/jobs", json={**body, "relief_edits": {**saved_edits, **bad}})
        detail = answer.json()["detail"]
        assert answer.status_code == 400 and words in detail and "\n" not in detail, (bad, detail)
    # a result made before barkgen kept the photo's light: its light stays, its depth may change
    library = client.app.state.library
    old = library.result(result["id"])
    files = {n: library.result_file(old.id, n) for n in old.files if n != "illumination.png"}
    older = library.add_result(old.exemplar_id, old.params, old.seed, files)
    page = client.get(f"/api/results/{older.id}").json()
    assert page["material"]["illumination_url"] is None
    assert client.get(f"/api/results/{older.id}/illumination").status_code == 404
    answer = client.post("/api/jobs", json={**body, "relief_edits": {**saved_edits, "result_id": older.id}})
    assert answer.status_code == 400 and "no record of its photo's light" in answer.json()["detail"]
    own_light = {**saved_edits, "result_id": older.id, "light_equalization": 1.0}
    queued = client.post("/api/jobs", json={**body, "relief_edits": own_light})
    assert queued.status_code == 201
    client.delete(f"/api/jobs/{queued.json()['id']}")  # (its run proves nothing more)
