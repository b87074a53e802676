"""The Blender preset wired by Blender itself (issue 32): Node Wrangler's "Add Principled Setup"
takes the set's one normal map (OpenGL) through a Normal Map node, the colour as sRGB and the
data maps as Non-Color; on today's ambientCG layout it picks NormalDX, which is why the preset
exists. Skipped, saying why, where Debian's ``blender`` is not installed (scripts/test.sh
installs it where it can)."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest

from barkgen.io import encode_material, write_bytes_atomic

SCRIPT = Path(__file__).with_name("blender_node_wrangler.py")


def node_wrangler_setup(folder: Path) -> dict:
    blender = shutil.which("blender")
    if blender is None:
        pytest.skip("needs Blender (Debian package blender; scripts/test.sh installs it where apt can)")
    out = subprocess.run(
        [blender, "-b", "--factory-startup", "--python", str(SCRIPT), "--", str(folder)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    line = next((l for l in out.stdout.splitlines() if l.startswith("BARKGEN-JSON")), None)
    assert line is not None, out.stdout[-2000:] + out.stderr[-2000:]
    return json.loads(line[len("BARKGEN-JSON") :])


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
