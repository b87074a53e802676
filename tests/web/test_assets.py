"""three.js for the web app (:mod:`barkgen.web.assets`): ``barkgen serve`` says in one line at
start when it is missing (the 3D panel was silently off after ``pip install``), and nothing
when it is there. The wheel that carries it: tests/test_wheel.py."""

from __future__ import annotations

import socket

import pytest

pytest.importorskip("fastapi")

import barkgen.web  # noqa: E402
from barkgen.web import assets  # noqa: E402


def _vendor(folder, version=assets.THREE_VERSION):
    for target in assets.THREE_FILES.values():
        (folder / target).parent.mkdir(parents=True, exist_ok=True)
        (folder / target).write_text("// three\n")
    (folder / "VERSION").write_text(version + "\n")
    return folder


def test_the_missing_warning_is_one_line_naming_the_fix(tmp_path):
    line = assets.missing_warning(tmp_path)
    assert line is not None and "\n" not in line
    assert line.startswith("barkgen: warning: three.js") and "3D" in line
    assert "python -m barkgen.web.assets" in line
    assert assets.missing_warning(_vendor(tmp_path)) is None
    # another version's files are as good as missing
    assert assets.missing_warning(_vendor(tmp_path, "0.1.0")) is not None


@pytest.mark.parametrize("present", [False, True])
def test_serve_warns_at_start_only_when_three_js_is_missing(tmp_path, monkeypatch, capsys, present):
    from barkgen.cli.serve import serve_command

    vendor = tmp_path / "vendor"
    vendor.mkdir()
    monkeypatch.setattr(assets, "VENDOR", _vendor(vendor) if present else vendor)
    monkeypatch.setattr(
        barkgen.web, "serve", lambda lib, host, port, limits, on_ready, **_: on_ready(f"http://{host}:{port}/")
    )
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    serve_command(port=port, library=tmp_path / "lib")
    lines = capsys.readouterr().err.splitlines()
    assert lines[0].startswith("barkgen is running at")
    warned = [line for line in lines if "three.js" in line]
    assert warned == ([] if present else [assets.missing_warning(vendor)])
