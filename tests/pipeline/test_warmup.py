"""barkgen.warm_up(): the Python API of ``barkgen warm-up`` (its CLI test compiles for real:
tests/cli/test_cli.py). Here its stages, their order and checks, with the stages stubbed."""

from __future__ import annotations

import pytest

import barkgen
from barkgen._shared import compile_notice
from barkgen.errors import InvalidInputError
from barkgen.pipeline import warmup


@pytest.fixture
def stubbed(monkeypatch):
    ran = []

    def stage(name):
        def run(*args):
            ran.append((name, compile_notice._state["quiet"] > 0))

        return run

    monkeypatch.setattr(warmup, "_crop", lambda: "crop")
    for name in warmup.STAGES:
        monkeypatch.setattr(warmup, f"_{name}", stage(name))
    return ran


def test_warm_up_is_public_and_runs_every_stage_in_order_without_the_notice(stubbed):
    assert barkgen.warm_up is warmup.warm_up and "warm_up" in barkgen.__all__
    seen = []
    seconds = barkgen.warm_up(on_stage=lambda stage, s: seen.append(stage))
    assert stubbed == [(s, True) for s in warmup.STAGES]  # quiet: it compiles on purpose
    assert list(seconds) == seen == list(warmup.STAGES) and all(s >= 0 for s in seconds.values())
    assert compile_notice._state["quiet"] == 0


@pytest.mark.parametrize(
    "stages, ran",
    [
        (["synth"], ["synth"]),
        ("preview", ["generate", "preview"]),  # the preview renders generate's files
        (" synth , preview ", ["synth", "generate", "preview"]),
    ],
)
def test_warm_up_runs_the_stages_asked_for(stubbed, stages, ran):
    assert list(barkgen.warm_up(stages)) == ran
    assert [name for name, _ in stubbed] == ran


@pytest.mark.parametrize("stages", ["nope", ["synth", "gen"], "", [" "]])
def test_warm_up_refuses_unknown_stages_before_any_work(stubbed, stages):
    with pytest.raises(InvalidInputError, match="choose from synth, generate, preview"):
        barkgen.warm_up(stages)
    assert stubbed == []


def test_the_cli_lists_the_same_stages():
    pytest.importorskip("typer")
    from barkgen.cli import warmup as cli_warmup

    assert cli_warmup.STAGES == warmup.STAGES
