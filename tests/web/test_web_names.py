"""The web app's names and defaults as an artist's library expects them (issue 66): every
download named after its material set (``ASSET_VARIANT_SIZE``, :mod:`barkgen.io.asset_names`),
a relief-edited or painted result under a name of its own, a set's zip its own library entry,
and the form's defaults the CLI's but for the differences named in ``WEB_DEFAULTS``."""

from __future__ import annotations

import io
import json
import zipfile

import numpy as np
import pytest
from fastapi.testclient import TestClient
from test_web_api import _photo_png, _set_zip, _wait

from barkgen.io.asset_names import edit_tag
from barkgen.library import Library
from barkgen.web import create_app

SETTINGS = {"size": "128x64", "k": 2, "tile": True, "material": True, "seed": 4}
SET = "Oak-bark-moss-1_seed4_128x64"


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    folder = tmp_path_factory.mktemp("names")
    with TestClient(create_app(Library(folder / "lib"))) as client:
        exemplar = client.post(
            "/api/exemplars",
            files={"file": ("oak.png", _photo_png(seed=5))},
            data={"name": "Oak bark (moss) #1", "licence": "CC0 (the tests')"},
        ).json()
        job = _wait(client, client.post("/api/jobs", json={"exemplar_id": exemplar["id"], **SETTINGS}).json()["id"])
        assert job["state"] == "done", job
        yield client, client.get(f"/api/results/{job['result_id']}").json()


def _zip(response) -> tuple[str, zipfile.ZipFile]:
    assert response.status_code == 200, response.text
    disposition = response.headers["content-disposition"]
    return disposition.split('filename="')[1].rstrip('"'), zipfile.ZipFile(io.BytesIO(response.content))


def test_the_zip_the_glb_and_the_blender_set_carry_the_sets_name(served):
    client, result = served
    assert result["set_name"] == SET and result["params"]["set_name"] == SET
    assert f"{SET}_Color.png" in result["files"] and f"{SET}_blender.py" in result["files"]
    record = json.loads(client.get(result["files"][f"{SET}.json"]).content)
    assert (record["asset"], record["variant"], record["source_licence"]) == (
        "Oak-bark-moss-1",
        "seed4",
        "CC0 (the tests')",
    )
    name, archive = _zip(client.get(result["download_url"]))
    assert name == f"{SET}.zip" == result["downloads"]["zip"]["name"]
    names = archive.namelist()
    assert all(n.startswith((f"{SET}_", f"{SET}.")) for n in names), names
    for own in ("texture.png", "report.json", "trunk.glb", "README.txt", "Color.png", "blender.py", "reference.png"):
        assert f"{SET}_{own}" in names, own
    assert f"{SET}.json" in names and not any("level_" in n or "thumbnail" in n for n in names)
    readme = archive.read(f"{SET}_README.txt").decode()
    assert "Photo licence: CC0 (the tests')" in readme and f"{SET}_trunk.glb" in readme
    # the trunk under the set's name; the set with its Blender set-up as a zip of its own
    assert result["downloads"]["glb"] == {"url": result["files"]["trunk.glb"], "name": f"{SET}_trunk.glb"}
    blender = result["downloads"]["blender"]
    assert blender["name"] == f"{SET}_blender.zip"
    name, archive = _zip(client.get(blender["url"]))
    assert name == blender["name"]
    assert f"{SET}_blender.py" in archive.namelist() and f"{SET}_Color.png" in archive.namelist()
    assert f"{SET}_texture.png" not in archive.namelist() and f"{SET}_trunk.glb" not in archive.namelist()
    script = archive.read(f"{SET}_blender.py").decode()
    assert f"{SET}_Color.png" in script
    # the thumbnail in the result's aspect (the page shows it uncropped)
    from barkgen.io import decode_image

    thumbnail = decode_image(client.get(result["thumbnail_url"]).content)
    assert thumbnail.shape[:2] == (64, 128)


def test_a_relief_edited_result_downloads_under_its_own_name(served):
    client, result = served
    saved = {"result_id": result["id"], "edits": [], "relief": 2.0}
    body = {"exemplar_id": result["exemplar_id"], **SETTINGS, "relief_edits": saved}
    job = _wait(client, client.post("/api/jobs", json=body).json()["id"])
    assert job["state"] == "done", job
    edited = client.get(f"/api/results/{job['result_id']}").json()
    document = json.loads(client.get(edited["files"]["edits.json"]).content)
    own = f"Oak-bark-moss-1_seed4-{edit_tag(document)}_128x64"
    assert edited["set_name"] == own != result["set_name"]
    name, archive = _zip(client.get(edited["download_url"]))
    assert name == f"{own}.zip" and f"{own}_edits.json" in archive.namelist()
    readme = archive.read(f"{own}_README.txt").decode()
    assert f"Relief-edited from result {result['id']}" in readme
    line = next(line for line in readme.splitlines() if line.startswith(f"{own}_edits.json"))
    assert "relief editor" in line and "material set's record" not in line
    assert json.loads(client.get(edited["files"][f"{own}.json"]).content)["variant"] == f"seed4-{edit_tag(document)}"


def test_a_painted_result_has_a_variant_of_its_own():
    from barkgen.web.routes_jobs import set_names

    level = np.arange(12, dtype=np.uint8).reshape(3, 4)
    plain = set_names("Oak bark", 7)
    painted = set_names("Oak bark", 7, resume=(1, level))
    assert plain == ("Oak-bark", "seed7")
    assert (
        painted[0] == "Oak-bark" and painted[1].startswith("seed7-paint") and len(painted[1]) == len("seed7-paint") + 6
    )
    assert set_names("Oak bark", 7, resume=(1, level[::-1])) != painted  # another painting, another name
    assert set_names("Oak bark", 7, resume=(1, level)) == painted


def test_a_sets_zip_is_an_entry_of_its_own_beside_the_photo_of_its_colour(served):
    client, _ = served
    data, _ = _set_zip()
    colour = zipfile.ZipFile(io.BytesIO(data)).read("Bark099_1K-PNG/Bark099_1K-PNG_Color.png")
    photo = client.post("/api/exemplars", files={"file": ("colour.png", colour)}, data={"name": "My photo"})
    assert photo.status_code == 201 and photo.json()["existing"] is False
    zipped = client.post("/api/exemplars", files={"file": ("Bark099_1K-PNG.zip", data)})
    assert zipped.status_code == 201, zipped.text
    assert zipped.json()["existing"] is False and zipped.json()["id"] != photo.json()["id"]
    entry = client.get(f"/api/exemplars/{zipped.json()['id']}").json()
    assert entry["name"] == "Bark099" and entry["maps"] == ["normal_gl", "roughness"]
    kept = client.get(f"/api/exemplars/{photo.json()['id']}").json()
    assert kept["name"] == "My photo" and kept["maps"] == []
    # the same zip, or the same photo, again: their entries
    assert client.post("/api/exemplars", files={"file": ("again.zip", data)}).json() == {
        "id": entry["id"],
        "existing": True,
    }
    again = client.post("/api/exemplars", files={"file": ("again.png", colour)}).json()
    assert again == {"id": kept["id"], "existing": True}


def test_the_forms_defaults_are_the_clis_but_the_named_differences(served):
    """``/api/options``'s defaults are ``barkgen generate``'s (GenerateOptions') for every field
    but those ``WEB_DEFAULTS`` names, and it names only these: a random seed, material on."""
    from barkgen._shared.options import option_fields
    from barkgen.pipeline import GenerateOptions
    from barkgen.web.routes_jobs import WEB_DEFAULTS

    client, _ = served
    assert WEB_DEFAULTS == {"seed": None, "material": True}
    fields = {f["name"]: f for f in client.get("/api/options").json()["fields"]}
    cli = {f.name: f for f in option_fields(GenerateOptions, "cli")}
    assert set(fields) <= set(cli)
    for name, field in fields.items():
        expected = WEB_DEFAULTS[name] if name in WEB_DEFAULTS else cli[name].json_value(cli[name].default_text)
        assert field["default"] == expected, name
    # a request that leaves them out gets them (material on)
    from barkgen.web.routes_jobs import page_default_options

    assert page_default_options()["material"] is True
