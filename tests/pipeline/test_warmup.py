"""barkgen.warm_up(): the Python API of ``barkgen warm-up`` (its CLI test compiles for real:
tests/cli/test_cli.py). Here its stages, their order and checks, with the stages stubbed."""

from __future__ import annotations

import json

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
    monkeypatch.setattr(warmup, "_crack_networks", stage("networks"))
    return ran


def test_warm_up_is_public_and_runs_every_stage_in_order_without_the_notice(stubbed):
    assert barkgen.warm_up is warmup.warm_up and "warm_up" in barkgen.__all__
    seen = []
    seconds = barkgen.warm_up(on_stage=lambda stage, s: seen.append(stage), parallel=False)
    assert stubbed == [(s, True) for s in warmup.STAGES]  # quiet: it compiles on purpose
    assert list(seconds) == seen == list(warmup.STAGES) and all(s >= 0 for s in seconds.values())
    assert compile_notice._state["quiet"] == 0


@pytest.mark.parametrize(
    "stages, ran",
    [
        (["synth"], ["synth"]),
        ("preview", ["generate", "preview"]),  # the preview renders generate's files
        (" synth , preview ", ["synth", "generate", "preview"]),
        ("bilayer,synth", ["synth", "bilayer"]),  # in their order
    ],
)
def test_warm_up_runs_the_stages_asked_for(stubbed, stages, ran):
    assert list(barkgen.warm_up(stages, parallel=False)) == ran
    assert [name for name, _ in stubbed] == ran


@pytest.mark.parametrize("stages", ["nope", ["synth", "gen"], "", [" "]])
def test_warm_up_refuses_unknown_stages_before_any_work(stubbed, stages):
    with pytest.raises(InvalidInputError, match="choose from synth, generate, preview, cracks, bilayer"):
        barkgen.warm_up(stages)
    assert stubbed == []


def test_the_cli_lists_the_same_stages():
    pytest.importorskip("typer")
    from barkgen.cli import warmup as cli_warmup

    assert cli_warmup.STAGES == warmup.STAGES


def test_in_two_processes_the_child_runs_the_solver_stages_and_this_one_the_rest(monkeypatch):
    """The split of a warm-up in two (the child's stages are given to a stand-in child here);
    a child that fails leaves every stage to this process."""
    ran = []
    monkeypatch.setattr(warmup, "_crop", lambda: "crop")
    monkeypatch.setattr(warmup, "_crack_networks", lambda: ran.append("networks"))
    monkeypatch.setattr(warmup, "_run_stage", lambda stage, crop, folder, grown: ran.append((stage, grown)))

    class Child:
        def __init__(self, stages, returncode):
            self.stages, self.returncode = stages, returncode

        def communicate(self):
            return json.dumps({"seconds": {s: 1.0 for s in self.stages}, "compiled": []}) + "\n", ""

        def poll(self):
            return self.returncode

    monkeypatch.setattr(warmup, "_start_child", lambda stages, folder: Child(stages, 0))
    seen = []
    seconds = barkgen.warm_up(on_stage=lambda stage, s: seen.append(stage), parallel=True)
    assert ran == ["networks", ("cracks", True), ("bilayer", True)]
    assert list(seconds) == list(warmup.STAGES) and seconds["synth"] == 1.0
    assert seen == list(warmup.STAGES)
    ran.clear()
    monkeypatch.setattr(warmup, "_start_child", lambda stages, folder: Child(stages, 1))
    barkgen.warm_up(parallel=True)
    assert ran == ["networks"] + [(s, True) for s in warmup.STAGES]


def test_a_kernel_compiled_in_both_processes_is_compiled_again_in_a_new_one(monkeypatch):
    """Two processes that compile one kernel at once may each write its cache index whole (one
    signature lost): its index is dropped and every stage runs again in a new process."""
    ran, started, dropped = [], [], []
    monkeypatch.setattr(warmup, "_crop", lambda: "crop")
    monkeypatch.setattr(warmup, "_crack_networks", lambda: ran.append("networks"))
    monkeypatch.setattr(warmup, "_run_stage", lambda stage, crop, folder, grown: ran.append(stage))
    monkeypatch.setattr(warmup, "_drop_indexes", lambda names: dropped.extend(sorted(names)))

    class Compiles:
        names = {"barkgen.k.shared", "barkgen.k.mine"}

        def close(self):
            pass

    class Child:
        returncode = 0

        def __init__(self, stages):
            self.stages = stages
            started.append(stages)

        def communicate(self):
            answer = {"seconds": {s: 1.0 for s in self.stages}, "compiled": ["barkgen.k.shared", "barkgen.k.theirs"]}
            return json.dumps(answer) + "\n", ""

        def poll(self):
            return 0

    monkeypatch.setattr(warmup, "_Compiles", Compiles)
    monkeypatch.setattr(warmup, "_start_child", lambda stages, folder: Child(stages))
    barkgen.warm_up(parallel=True)
    assert dropped == ["barkgen.k.shared"]
    assert started == [list(warmup.CHILD_STAGES), list(warmup.STAGES)] and ran == ["networks"]
