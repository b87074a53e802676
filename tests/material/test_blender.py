"""Sets wired by Blender itself. The Blender preset (issue 32): Node Wrangler's "Add Principled
Setup" takes the set's one normal map (OpenGL) through a Normal Map node, the colour as sRGB and
the data maps as Non-Color; on today's ambientCG layout it picks NormalDX, which is why the
preset exists. Every set's ``NAME_blender.py`` (issue 65): run by Blender, it makes the material
and a plane at the set's real-world size, displaced by as much as ``NAME.json`` says. Skipped,
saying why, where Debian's ``blender`` is not installed (scripts/test.sh installs it where it
can); the scripts' text is checked without it."""

from __future__ import annotations

import ast
import dataclasses
import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from barkgen.io import encode_material, write_bytes_atomic
from barkgen.material import MaterialSet
from barkgen.material.presets import PRESETS

SCRIPT = Path(__file__).with_name("blender_node_wrangler.py")
CHECK = Path(__file__).with_name("blender_setup_check.py")


def run_blender(*args: str) -> list[dict]:
    """Blender in the background on ``args``; the JSON lines its scripts printed."""
    blender = shutil.which("blender")
    if blender is None:
        pytest.skip("needs Blender (Debian package blender; scripts/test.sh installs it where apt can)")
    out = subprocess.run(
        [blender, "-b", "--factory-startup", "--python-exit-code", "1", *args],
        capture_output=True,
        text=True,
        timeout=300,
    )
    lines = [json.loads(l[len("BARKGEN-JSON") :]) for l in out.stdout.splitlines() if l.startswith("BARKGEN-JSON")]
    assert out.returncode == 0 and lines, out.stdout[-2000:] + out.stderr[-2000:]
    return lines


def node_wrangler_setup(folder: Path) -> dict:
    return run_blender("--python", str(SCRIPT), "--", str(folder))[0]


def write_set(folder: Path, preset: str) -> None:
    from test_presets import small_set

    for name, data in encode_material(small_set(metalness=True), "bark", preset).items():
        write_bytes_atomic(folder / name, data)


def test_node_wrangler_wires_the_blender_preset(tmp_path):
    write_set(tmp_path, "blender")
    report = node_wrangler_setup(tmp_path)
    assert report["finished"]
    assert report["wired"]["Normal"] == "bark_NormalGL.png" and report["normal_map_node"]
    assert report["wired"]["Base Color"] == "bark_Color.png"
    assert report["wired"]["Roughness"] == "bark_Roughness.png"
    assert report["wired"]["Metallic"] == "bark_Metalness.png"
    spaces = report["colour_spaces"]
    assert spaces.pop("bark_Color.png") == "sRGB"
    assert spaces and set(spaces.values()) == {"Non-Color"}, spaces


def test_node_wrangler_takes_directx_normals_from_the_ambientcg_layout(tmp_path):
    """The problem the Blender preset solves: with both conventions there, Node Wrangler wires
    NormalDX (it sorts first), and Blender's normals are OpenGL."""
    write_set(tmp_path, "ambientcg")
    report = node_wrangler_setup(tmp_path)
    assert report["wired"]["Normal"] == "bark_NormalDX.png"


def relief_set(metalness: bool = False, opacity: bool = False) -> MaterialSet:
    """A 32 x 24 px set 1 cm a pixel whose height is smooth (a vertex a pixel samples its whole
    range), lopsided (midlevel 0.38, not 0.5) and of mean 0 (the plane's mean height is 0)."""
    from scipy.special import i0

    h, w = 24, 32
    y, x = np.mgrid[0:h, 0:w] + 0.5
    height = 1.2 * (np.exp(np.sin(2 * np.pi * x / w)) - i0(1)) + 0.4 * np.sin(2 * np.pi * y / h)
    rng = np.random.default_rng(3)
    normals = np.zeros((h, w, 3), np.float32)
    normals[..., 2] = 1
    return MaterialSet(
        color=rng.random((h, w, 3), dtype=np.float32),
        height=height.astype(np.float32),
        normals=normals,
        ao=np.ones((h, w), np.float32),
        roughness=rng.random((h, w), dtype=np.float32),
        metalness=rng.random((h, w), dtype=np.float32) if metalness else None,
        opacity=rng.random((h, w), dtype=np.float32) if opacity else None,
        pixel_size_m=0.01,
        size_given=True,
    )


def write(material: MaterialSet, folder: Path, name: str, preset: str = "ambientcg") -> dict:
    """The set's files in ``folder``; its NAME.json."""
    folder.mkdir(exist_ok=True)
    for file, data in encode_material(material, name, preset).items():
        write_bytes_atomic(folder / file, data)
    return json.loads((folder / f"{name}.json").read_text())


def script_values(text: str) -> dict:
    """The literal constants a set's script assigns (DEPTH_M, MAPS, ...)."""
    tree = ast.parse(text)
    return {
        node.targets[0].id: ast.literal_eval(node.value)
        for node in tree.body
        if isinstance(node, ast.Assign)
        and node.targets[0].id.isupper()
        and not isinstance(node.value, (ast.Name, ast.IfExp))
    }


@pytest.mark.parametrize("preset", PRESETS)
def test_every_set_has_a_blender_script_of_its_json_values(preset):
    """No Blender needed: each preset's NAME_blender.py is Python that embeds NAME.json's sizes
    and reads only the set's own files; a set of unknown size is taken as 1 m wide."""
    material = relief_set(metalness=True, opacity=True)
    files = encode_material(material, "bark", preset)
    meta = json.loads(files["bark.json"])
    assert "bark_blender.py" in meta["files"]
    text = files["bark_blender.py"].decode()
    compile(text, "bark_blender.py", "exec")
    values = script_values(text)
    assert values["DEPTH_M"] == meta["displacement_depth_m"] and values["MIDLEVEL"] == meta["displacement_midlevel"]
    assert (values["WIDTH_M"], values["HEIGHT_M"]) == (meta["width_m"], meta["height_m"]) == (0.32, 0.24)
    assert {file for file, _ in values["MAPS"].values()} <= set(files)
    assert {"color", "normal", "roughness", "metalness", "opacity", "displacement"} == set(values["MAPS"])
    unknown = dataclasses.replace(material, pixel_size_m=None, metalness=None, opacity=None)
    files = encode_material(unknown, "bark", preset)
    values, meta = script_values(files["bark_blender.py"].decode()), json.loads(files["bark.json"])
    assert "width_m" not in meta and values["WIDTH_M"] == 1.0 and values["HEIGHT_M"] == 0.75
    assert values["DEPTH_M"] == meta["displacement_depth"] and set(values["MAPS"]).isdisjoint({"metalness", "opacity"})


def test_the_blender_script_sets_the_set_up_at_its_real_size(tmp_path):
    """``blender -b --python NAME_blender.py -- --render``: the material's Displacement node and
    the plane's Displace modifier hold NAME.json's depth and midlevel, the plane is the set 2 x 2
    at its real size, its vertices rise and fall by the depth in metres around 0, each map is
    wired in its colour space, and a Cycles render is written."""
    meta = write(relief_set(metalness=True), tmp_path / "set", "bark")
    render = tmp_path / "render.png"
    script = str(tmp_path / "set" / "bark_blender.py")
    options = ["--render", str(render), "--resolution", "64", "--samples", "4"]
    (report,) = run_blender("--python", script, "--python", str(CHECK), "--", *options)
    depth, midlevel = meta["displacement_depth_m"], meta["displacement_midlevel"]
    disp = report["displacement"]
    assert disp["scale"] == pytest.approx(depth, rel=1e-6) and disp["midlevel"] == pytest.approx(midlevel, rel=1e-6)
    assert disp["height"] == ["bark_Displacement.png:Color"] and disp["to_output"] == ["DISPLACEMENT:Displacement"]
    assert disp["method"] == "BUMP"  # the Displace modifier moves the plane: nothing displaces twice
    modifier = report["modifiers"]["DISPLACE"]
    assert modifier["strength"] == pytest.approx(depth, rel=1e-6) and modifier["texture_coords"] == "UV"
    assert modifier["mid_level"] == pytest.approx(midlevel, rel=1e-6)
    assert report["modifiers"]["SUBSURF"]["subdivision_type"] == "SIMPLE"
    assert report["plane"]["width"] == pytest.approx(2 * meta["width_m"], rel=1e-6)
    assert report["plane"]["height"] == pytest.approx(2 * meta["height_m"], rel=1e-6)
    assert report["uv"] == [0.0, 2.0, 0.0, 2.0]
    heights = report["heights"]
    assert heights["n"] >= 4 * 32 * 24  # about a vertex a pixel
    assert heights["max"] - heights["min"] == pytest.approx(depth, rel=0.03)
    assert abs(heights["mean"]) < 0.02 * depth
    assert heights["min"] == pytest.approx(-midlevel * depth, rel=0.03)
    assert report["wired"] == {
        "Base Color": ["bark_Color.png:Color"],
        "Normal": ["NORMAL_MAP:Normal", "bark_NormalGL.png:Color"],
        "Roughness": ["bark_Roughness.png:Color"],
        "Metallic": ["bark_Metalness.png:Color"],
        "Alpha": [],
    }
    spaces = report["colour_spaces"]
    assert spaces.pop("bark_Color.png") == "sRGB" and set(spaces.values()) == {"Non-Color"}
    from barkgen.io import read_image

    image = read_image(render)
    assert image.shape[:2] == (64, 64) and image.std() > 5


def test_the_blender_script_reads_packed_presets_through_their_channels(tmp_path):
    """The engines' layouts set up alike: ORM's G and B as roughness and metallic, Unity's
    MaskMap R as metallic and 1 - A as roughness (its channels kept apart), opacity from the
    base colour's alpha, Unreal's DirectX normals with their green flipped; run from Blender's
    Text Editor (no ``__file__``: the text's own file says where the maps are) too."""
    material = relief_set(metalness=True, opacity=True)
    args = []
    for preset in ("unreal", "unity", "gltf"):
        write(material, tmp_path / preset, preset, preset)
        args += ["--python", str(tmp_path / preset / f"{preset}_blender.py")]
    write(material, tmp_path / "editor", "editor", "blender")
    path = str(tmp_path / "editor" / "editor_blender.py")
    text_editor = f"import bpy; t = bpy.data.texts.load({path!r}); exec(compile(t.as_string(), t.name, 'exec'), {{}})"
    reports = {r["object"]: r for r in run_blender(*args, "--python-expr", text_editor, "--python", str(CHECK))}
    assert sorted(reports) == ["editor", "gltf", "unity", "unreal"]
    wired = {name: r["wired"] for name, r in reports.items()}
    for preset in ("unreal", "gltf"):
        assert wired[preset]["Roughness"] == ["SEPARATE_COLOR:Green", f"{preset}_ORM.png:Color"]
        assert wired[preset]["Metallic"] == ["SEPARATE_COLOR:Blue", f"{preset}_ORM.png:Color"]
    assert wired["unreal"]["Normal"] == [
        "NORMAL_MAP:Normal",
        "COMBINE_COLOR:Color",
        "MATH:Value",
        "SEPARATE_COLOR:Green",
        "unreal_NormalDX.png:Color",
    ]
    assert wired["unreal"]["Alpha"] == ["unreal_Opacity.png:Color"]
    assert wired["unity"]["Roughness"] == ["MATH:Value", "unity_MaskMap.png:Alpha"]
    assert wired["unity"]["Metallic"] == ["SEPARATE_COLOR:Red", "unity_MaskMap.png:Color"]
    assert wired["unity"]["Alpha"] == ["unity_BaseMap.png:Alpha"] and wired["gltf"]["Alpha"] == [
        "gltf_BaseColor.png:Alpha"
    ]
    assert reports["unity"]["alpha_modes"]["unity_MaskMap.png"] == "CHANNEL_PACKED"
    assert wired["editor"]["Normal"] == ["NORMAL_MAP:Normal", "editor_NormalGL.png:Color"]
    depth = material.physical_size()["displacement_depth_m"]
    for report in reports.values():
        heights = report["heights"]
        assert heights["max"] - heights["min"] == pytest.approx(depth, rel=0.03), report["object"]


def test_the_blender_script_can_leave_the_displacement_to_cycles(tmp_path):
    """``--displacement shader``: no Displace modifier (the plane stays flat until Cycles
    renders it), the material displaces and bumps; ``--save`` writes the .blend."""
    write(relief_set(), tmp_path, "bark")
    saved = tmp_path / "bark.blend"
    args = ["--python", str(tmp_path / "bark_blender.py"), "--python", str(CHECK)]
    (report,) = run_blender(*args, "--", "--displacement", "shader", "--save", str(saved))
    assert report["displacement"]["method"] == "BOTH" and "DISPLACE" not in report["modifiers"]
    assert report["heights"]["min"] == report["heights"]["max"] == 0.0
    assert saved.stat().st_size > 0


def test_a_udim_set_is_one_tiled_image_a_map_on_a_plane_over_its_tiles(tmp_path):
    """A set in 2 x 1 UDIM tiles (issue 69): each map one tiled image holding tiles 1001 and
    1002, on a plane of the set's own size whose UVs run 0..2 x 0..1, displaced by the material
    alone (the Displace modifier reads one tile; Cycles' bump draws a line along the tile
    border); the render, aimed at the tiles' border, is written."""
    folder = tmp_path / "set"
    folder.mkdir()
    files = encode_material(relief_set(), "bark", udim=(2, 1))
    for file, data in files.items():
        write_bytes_atomic(folder / file, data)
    meta = json.loads(files["bark.json"])
    render = tmp_path / "render.png"
    args = ["--python", str(folder / "bark_blender.py"), "--python", str(CHECK)]
    (report,) = run_blender(
        *args, "--", "--render", str(render), "--resolution", "48", "--samples", "2", "--focus", "1,0.5"
    )
    assert report["displacement"]["method"] == "DISPLACEMENT" and "DISPLACE" not in report["modifiers"]
    assert report["uv"] == [0.0, 2.0, 0.0, 1.0]
    assert report["plane"]["width"] == pytest.approx(meta["width_m"], rel=1e-6)
    assert report["plane"]["height"] == pytest.approx(meta["height_m"], rel=1e-6)
    assert set(report["tiles"]) == {f"bark_{m}.1001.png" for m in ("Color", "NormalGL", "Displacement", "Roughness")}
    assert all(tiles == [1001, 1002] for tiles in report["tiles"].values())
    from barkgen.io import read_image

    assert read_image(render).std() > 5
    _, error = run_blender_failing(folder / "bark_blender.py", "--displacement", "modifier")
    assert "a UDIM set is displaced by the material" in error


def run_blender_failing(script: Path, *options: str) -> tuple[int, str]:
    """A set's script run by Blender with ``options``, expected to refuse them: its exit code
    and what it printed."""
    blender = shutil.which("blender")
    if blender is None:
        pytest.skip("needs Blender (Debian package blender; scripts/test.sh installs it where apt can)")
    out = subprocess.run(
        [blender, "-b", "--factory-startup", "--python-exit-code", "1", "--python", str(script), "--", *options],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert out.returncode != 0
    return out.returncode, out.stdout + out.stderr
