"""Every file of a material set carries its asset, variant and size (barkgen.io.asset_names):
generate, material, export-glb and batch, and no two runs' sets share a name."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from conftest import run

from barkgen.io import write_png


@pytest.fixture(scope="module")
def photo(tmp_path_factory, synthetic_exemplar) -> Path:
    p = tmp_path_factory.mktemp("photo") / "Oak bark #1.png"  # (not file-safe as it is)
    write_png(p, synthetic_exemplar)
    return p


def _set_files(folder: Path) -> set[str]:
    """The files of the folder that are not the run's own (texture.png, report.json, ...)."""
    own = {"texture.png", "labels_in.png", "labels_out.png", "reference.png", "preview.png", "report.json"}
    return {p.name for p in folder.iterdir()} - own - {"illumination.png"}


def test_generate_names_every_set_file_by_asset_seed_and_size(tmp_path, photo):
    runs = {
        "seed1": ["--seed", "1"],
        "seed2": ["--seed", "2"],
        "sizes": ["--seed", "1", "--sizes", "32,64"],
        "edited": ["--seed", "1", "--edits", str(tmp_path / "edits.json")],
    }
    (tmp_path / "edits.json").write_text(json.dumps({"version": 1, "edits": [], "relief": 1.5}))
    names: dict[str, set[str]] = {}
    for key, args in runs.items():
        out = tmp_path / key
        r = run("generate", str(photo), "-o", str(out), "--size", "64x64", "--k", "2", "--material", "-q", *args)
        assert r.returncode == 0, r.stderr
        names[key] = _set_files(out)
    assert {n.split("_64x64")[0] for n in names["seed1"]} == {"Oak-bark-1_seed1"}
    assert "Oak-bark-1_seed1_64x64_Color.png" in names["seed1"]
    assert "Oak-bark-1_seed1_64x64.json" in names["seed1"] and "Oak-bark-1_seed1_64x64_blender.py" in names["seed1"]
    assert {"Oak-bark-1_seed1_32x32_Color.png", "Oak-bark-1_seed1_64x64_Color.png"} <= names["sizes"]
    edited = {n for n in names["edited"] if n.endswith("_Color.png")}
    assert len(edited) == 1 and edited.pop().startswith("Oak-bark-1_seed1-edit")
    # no two runs' sets collide (the sizes run repeats seed1's 64x64 set: the same bark)
    for a, b in (("seed1", "seed2"), ("seed1", "edited"), ("seed2", "edited"), ("sizes", "seed2")):
        assert not names[a] & names[b], (a, b, names[a] & names[b])
    meta = json.loads((tmp_path / "seed1" / "Oak-bark-1_seed1_64x64.json").read_text())
    assert (meta["asset"], meta["variant"], meta["width_px"], meta["height_px"]) == ("Oak-bark-1", "seed1", 64, 64)
    assert meta["source_licence"] is None and meta["preset"] == "ambientcg" and meta["width_m"] > 0


def test_name_and_licence_are_the_users(tmp_path, photo):
    out = tmp_path / "out"
    args = ["--size", "64x64", "--k", "2", "--material", "--name", "Bark042", "--licence", "CC0-1.0", "-q"]
    assert run("generate", str(photo), "-o", str(out), *args).returncode == 0
    assert "Bark042_64x64_Color.png" in _set_files(out)
    meta = json.loads((out / "Bark042_64x64.json").read_text())
    assert meta["source_licence"] == "CC0-1.0" and meta["asset"] == "Bark042" and meta["variant"] is None
    # the trunk named as the set is, where the command runs
    done = run("export-glb", str(out), "--segments", "16", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "Bark042_64x64_trunk.glb").read_bytes()[:4] == b"glTF"


def test_the_library_layout_keeps_runs_side_by_side_in_one_folder(tmp_path, photo):
    """--layout library: the run's own files named after its set too, so that several runs
    share a folder; a run again of one set replaces that set's files, and no other's."""
    lib = tmp_path / "lib"
    args = ["-o", str(lib), "--size", "64x64", "--k", "2", "--material", "--layout", "library", "-q"]
    for seed in ("1", "2"):
        assert run("generate", str(photo), *args, "--seed", seed).returncode == 0
    names = {p.name for p in lib.iterdir()}
    for seed in ("1", "2"):
        set_name = f"Oak-bark-1_seed{seed}_64x64"
        assert {f"{set_name}_texture.png", f"{set_name}_report.json", f"{set_name}_Color.png"} <= names
    assert all(n.startswith("Oak-bark-1_seed") for n in names), names  # every file: asset, variant, size
    # seed 1 again, without its material: its set's maps go, seed 2's stay
    plain = ["-o", str(lib), "--size", "64x64", "--k", "2", "--layout", "library", "-q"]
    done = run("generate", str(photo), *plain, "--seed", "1")
    assert done.returncode == 0, done.stderr
    after = {p.name for p in lib.iterdir()}
    assert "Oak-bark-1_seed1_64x64_Color.png" not in after and "Oak-bark-1_seed1_64x64_texture.png" in after
    assert {n for n in names if "seed2" in n} <= after
    assert run("generate", str(photo), "-o", str(lib), "--layout", "shelf", "-q").returncode == 2


def test_material_names_the_photos_own_set(tmp_path, photo):
    out = tmp_path / "m"
    assert run("material", str(photo), "-o", str(out), "--k", "2", "-q").returncode == 0
    assert "Oak-bark-1_40x48_Color.png" in {p.name for p in out.iterdir()}  # the photo's set: no seed


def test_batch_names_each_variant_by_exemplar_and_seed(tmp_path, photo):
    spec = tmp_path / "spec.json"
    spec.write_text(
        json.dumps(
            {
                "size": "64x64",
                "k": 2,
                "material": True,
                "exemplars": [{"name": "oak", "path": str(photo), "seeds": [3, 4], "licence": "CC-BY-4.0"}],
            }
        )
    )
    done = run("batch", str(spec), "-o", str(tmp_path / "out"), "--workers", "1", "-q")
    assert done.returncode == 0, done.stderr
    for seed in (3, 4):
        folder = next(p for p in (tmp_path / "out" / "oak").iterdir() if p.is_dir() and str(seed) in p.name)
        # the photo's own name, as generate names it (the entry's name is its folder's)
        meta = json.loads((folder / f"Oak-bark-1_seed{seed}_64x64.json").read_text())
        assert meta["source_licence"] == "CC-BY-4.0" and meta["variant"] == f"seed{seed}"
