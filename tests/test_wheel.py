"""barkgen installs as a library: the release path, end to end (issue 57, part 5).

The sdist is built from this tree and the wheel from the sdist (as ``python -m build`` does),
without any three.js the tree may hold, so the wheel's build fetches and checks it itself
(``setup.py``). The wheel goes into a fresh virtualenv with ``pip install 'WHEEL[web]'``
(its dependencies from pip's cache or index), and that venv's ``barkgen serve`` must serve the
pages and the three.js they import, without a word about it missing. A build that cannot fetch
three.js must fail, naming the fix.

Slow (a build, a venv and an install: about a minute with a warm pip cache) and an acceptance
test, so CI runs it; ``-m "not wheel"`` or ``BARKGEN_SKIP_WHEEL_TEST=1`` skips it locally.
"""

from __future__ import annotations

import importlib.util
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tarfile
import time
import urllib.request
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

pytestmark = [
    pytest.mark.wheel,
    pytest.mark.skipif(os.environ.get("BARKGEN_SKIP_WHEEL_TEST") == "1", reason="BARKGEN_SKIP_WHEEL_TEST=1"),
]


def _clean_env(**extra: str) -> dict[str, str]:
    """This environment without what would let the tree's barkgen in (PYTHONPATH) or
    change the build (the three.js switches), plus ``extra``."""
    env = {
        k: v
        for k, v in os.environ.items()
        if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV", "PYTHONSAFEPATH")
        and not k.startswith("BARKGEN_THREE")
        and k != "BARKGEN_BUILD_WITHOUT_THREE"
    }
    return env | extra


def _check(cmd: list[str], timeout: float, **kwargs) -> subprocess.CompletedProcess:
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, **kwargs)
    assert done.returncode == 0, f"{cmd}:\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}"
    return done


def _unpacked_sdist(sdist: Path, into: Path) -> Path:
    """The sdist unpacked into ``into``, minus any three.js the tree it came from held."""
    with tarfile.open(sdist) as archive:
        archive.extractall(into, **({"filter": "data"} if hasattr(tarfile, "data_filter") else {}))
    (root,) = into.iterdir()
    shutil.rmtree(root / "src" / "barkgen" / "web" / "static" / "vendor", ignore_errors=True)
    return root


def _build_wheel(source: Path, outdir: Path, env: dict[str, str]) -> subprocess.CompletedProcess:
    if importlib.util.find_spec("build") is not None:
        cmd = [sys.executable, "-m", "build", "--wheel", "--outdir", str(outdir), str(source)]
    else:  # pip builds in the source folder: a fresh copy of the sdist, so nothing stale
        cmd = [sys.executable, "-m", "pip", "wheel", "--no-deps", "-w", str(outdir), str(source)]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=900, env=env)


@pytest.fixture(scope="module")
def sdist(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("sdist")
    if importlib.util.find_spec("build") is not None:
        _check([sys.executable, "-m", "build", "--sdist", "--outdir", str(out), str(REPO)], 900, env=_clean_env())
    else:
        _check([sys.executable, "setup.py", "-q", "sdist", "-d", str(out)], 900, env=_clean_env(), cwd=REPO)
    (found,) = out.glob("barkgen-*.tar.gz")
    return found


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def _get(url: str) -> tuple[int, bytes]:
    with urllib.request.urlopen(url, timeout=30) as response:  # noqa: S310 - loopback
        return response.status, response.read()


def test_the_wheel_installs_in_a_fresh_venv_and_serves_three_js(sdist, tmp_path):
    started = time.monotonic()
    built = _build_wheel(_unpacked_sdist(sdist, tmp_path / "src"), tmp_path / "dist", _clean_env())
    assert built.returncode == 0, built.stderr[-3000:]
    assert "integrity checked" in built.stdout + built.stderr  # fetched by the build itself
    (wheel,) = (tmp_path / "dist").glob("barkgen-*.whl")
    venv = tmp_path / "venv"
    _check([sys.executable, "-m", "venv", str(venv)], 300)
    python, env = venv / "bin" / "python", _clean_env()
    t0 = time.monotonic()
    _check([str(python), "-m", "pip", "install", "--quiet", f"{wheel}[web]"], 900, env=env, cwd=tmp_path)
    install_s = time.monotonic() - t0
    where = _check([str(python), "-c", "import barkgen; print(barkgen.__file__)"], 60, env=env, cwd=tmp_path)
    assert Path(where.stdout.strip()).is_relative_to(venv), where.stdout  # the wheel's, not the tree's

    port, log = _free_port(), tmp_path / "serve.log"
    with open(log, "w") as out:
        server = subprocess.Popen(
            [str(venv / "bin" / "barkgen"), "serve", "--port", str(port), "--library", str(tmp_path / "lib")],
            stdout=out,
            stderr=subprocess.STDOUT,
            env=env,
            cwd=tmp_path,
        )
    try:
        deadline = time.monotonic() + 120
        while "running at" not in log.read_text():
            assert server.poll() is None and time.monotonic() < deadline, log.read_text()
            time.sleep(0.2)
        base = f"http://127.0.0.1:{port}"
        status, page = _get(f"{base}/")
        assert status == 200 and b"<html" in page.lower()
        # the result page's import map says where three.js is; that URL and what it imports
        status, page = _get(f"{base}/results/1")
        three = re.search(r'"three":\s*"([^"]+)"', page.decode())
        addons = re.search(r'"three/addons/":\s*"([^"]+)"', page.decode())
        assert status == 200 and three and addons, page[:2000]
        status, module = _get(base + three.group(1))
        assert status == 200 and b"three.core.js" in module
        assert _get(base + three.group(1).rsplit("/", 1)[0] + "/three.core.js")[0] == 200
        assert _get(base + addons.group(1) + "controls/OrbitControls.js")[0] == 200
        assert "three.js" not in log.read_text(), log.read_text()  # no "missing" warning
    finally:
        server.send_signal(signal.SIGTERM)
        try:
            server.wait(timeout=30)
        except subprocess.TimeoutExpired:
            server.kill()
            server.wait()
        shutil.rmtree(venv, ignore_errors=True)  # ~0.9 GB
    print(f"wheel test: {time.monotonic() - started:.0f} s, of which pip install {install_s:.0f} s")


def test_a_wheel_build_that_cannot_fetch_three_js_fails_naming_the_fix(sdist, tmp_path):
    source = _unpacked_sdist(sdist, tmp_path / "src")
    built = _build_wheel(source, tmp_path / "dist", _clean_env(BARKGEN_THREE_TARBALL=str(tmp_path / "none.tgz")))
    assert built.returncode != 0
    said = built.stdout + built.stderr
    assert "could not fetch three.js" in said and "BARKGEN_BUILD_WITHOUT_THREE=1" in said, said[-3000:]
    assert not list((tmp_path / "dist").glob("*.whl"))
