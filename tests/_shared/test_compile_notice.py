"""The word that barkgen's numba kernels compile (:mod:`barkgen._shared.compile_notice`): said
once, by the first compile of a cached kernel in a process (a cold cache), never when the
kernels come from the cache, never during :func:`barkgen.warm_up`; the CLI shows it as one
``barkgen: note:`` line where a progress bar would show."""

from __future__ import annotations

import logging
import os
import subprocess
import sys

import numba
import pytest

import barkgen
from barkgen._shared import compile_notice
from barkgen._shared.threads import thread_budget

#: one small cached kernel, called with two signatures: two compiles on a cold cache
CHILD = """
import numpy as np
from barkgen._shared import compile_notice
from barkgen.render._kernels import _bilinear
compile_notice.watch()
compile_notice.watch()
print(_bilinear(np.ones((2, 2, 1)), 0.5, 0.5, 0), _bilinear(np.ones((2, 2, 1), np.float32), 0.5, 0.5, 0))
"""


def _child(cache) -> subprocess.CompletedProcess:
    env = os.environ | {"NUMBA_CACHE_DIR": str(cache)}
    done = subprocess.run([sys.executable, "-c", CHILD], capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == 0 and done.stdout.split() == ["1.0", "1.0"], done.stderr
    return done


def test_a_cold_cache_says_so_once_and_a_warm_one_says_nothing(tmp_path):
    cold = _child(tmp_path)
    assert cold.stderr.count("compiling barkgen's numba kernels") == 1, cold.stderr
    assert cold.stderr.strip() == compile_notice.MESSAGE  # lastResort: the bare message
    assert any(tmp_path.rglob("*.nbi"))  # it did write its cache
    warm = _child(tmp_path)
    assert warm.stderr == "", warm.stderr


def test_only_barkgens_cached_kernels_count():
    from barkgen.nnf import _kernels as nnf_kernels
    from barkgen.render import _kernels as render_kernels

    assert compile_notice.is_cached_kernel(render_kernels.render_rows)
    assert not compile_notice.is_cached_kernel(nnf_kernels._far_from_kept)  # no cache: inlined

    @numba.njit
    def elsewhere(x):
        return x

    assert not compile_notice.is_cached_kernel(elsewhere)


def test_the_notice_is_logged_once_and_not_during_a_warm_up(monkeypatch, caplog):
    from barkgen.render._kernels import render_rows

    monkeypatch.setitem(compile_notice._state, "said", False)
    with caplog.at_level(logging.WARNING, logger="barkgen"):
        with compile_notice.quiet():
            compile_notice._on_compile(render_rows)
        assert caplog.records == []
        compile_notice._on_compile(render_rows)
        compile_notice._on_compile(render_rows)
    assert [(r.name, r.levelname, r.getMessage()) for r in caplog.records] == [
        ("barkgen.kernels", "WARNING", compile_notice.MESSAGE)
    ]
    assert "barkgen.warm_up()" in compile_notice.MESSAGE


def test_runs_and_the_package_face_start_watching(monkeypatch):
    monkeypatch.setitem(compile_notice._state, "watching", False)
    calls = []
    monkeypatch.setattr(compile_notice, "watch", lambda: calls.append("watch"))
    with thread_budget(1):
        pass
    assert barkgen.render_trunk is not None
    assert calls == ["watch", "watch"]


@pytest.mark.parametrize("show", [True, False])
def test_the_cli_shows_the_notice_as_one_note_line(capsys, show):
    pytest.importorskip("typer")
    from barkgen.cli.app import _show_notes

    try:
        _show_notes(show)
        logging.getLogger("barkgen.kernels").warning(compile_notice.MESSAGE)
    finally:
        _show_notes(False)
    err = capsys.readouterr().err
    assert err == (f"barkgen: note: {compile_notice.MESSAGE}\n" if show else "")
