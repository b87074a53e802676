"""One source for every option: the options classes' fields (barkgen._shared.options) make the
CLI's flags, the web API's request schema and the web form's fields (/api/options), a batch spec's
keys and report.json. Adding an option is the field (and the code that uses it, and its test):
a dummy field added here reaches every front end, or the test names the one that lacks it; the
same for a dummy field of MaterialOptions through ``barkgen material``."""

from __future__ import annotations

import dataclasses

import pytest

from barkgen._shared.options import FRONT_ENDS, check_options, option, option_fields, option_values
from barkgen.bilayer import AnalysisOptions, SynthesisOptions
from barkgen.branching import GrowOptions
from barkgen.errors import InvalidInputError
from barkgen.material import MaterialOptions
from barkgen.pipeline import GenerateOptions, analysis_key
from barkgen.synth import SynthesisConfig

#: every options class declared with option()
OPTIONS_CLASSES = (GenerateOptions, MaterialOptions, AnalysisOptions, SynthesisOptions, GrowOptions, SynthesisConfig)


@dataclasses.dataclass(frozen=True)
class DummyOptions(GenerateOptions):
    """GenerateOptions with one more option, declared as every option is."""

    dummy_strength: float = option(0.5, "A test's option.", kind=float, minimum=0, maximum=2, analysis=True)
    dummy_mode: str = option("soft", "A test's text option.", choices=("soft", "hard"), group="advanced")


@dataclasses.dataclass(frozen=True)
class DummyMaterialOptions(MaterialOptions):
    """MaterialOptions with one more option, declared as every option is."""

    dummy_gloss: float = option(0.25, "A test's material option.", kind=float, minimum=0, maximum=1)


class Captured(Exception):
    """Raised by the patched generate with the options it got."""


def _cli_options(monkeypatch, args: list[str]):
    """The options the CLI's generate makes of ``args`` with DummyOptions as its options class."""
    import typer
    from typer.testing import CliRunner

    import barkgen.pipeline
    from barkgen.cli import generate as generate_module
    from barkgen.cli._options import with_options

    command = with_options(DummyOptions)(generate_module.generate_command.bare)

    def capture(photo, options, **kwargs):
        raise Captured(options)

    monkeypatch.setattr(barkgen.pipeline, "generate", capture)
    app = typer.Typer()
    app.command()(command)
    app.command("other")(lambda: None)  # (two commands: typer keeps the name)
    result = CliRunner().invoke(app, ["generate-command", *args])
    assert isinstance(result.exception, Captured), f"the CLI lacks an option of the options class: {result.output}"
    return result.exception.args[0]


def test_a_new_field_reaches_the_cli(monkeypatch, tmp_path):
    options = _cli_options(
        monkeypatch,
        ["-o", str(tmp_path / "out"), "--dummy-strength", "1.5", "--dummy-mode", "hard", "--size", "64x48", "-q"],
    )
    assert isinstance(options, DummyOptions)
    assert (options.dummy_strength, options.dummy_mode, options.size) == (1.5, "hard", (48, 64))
    defaults = _cli_options(monkeypatch, ["-o", str(tmp_path / "out"), "-q"])
    assert (defaults.dummy_strength, defaults.dummy_mode) == (0.5, "soft")


def test_a_new_field_reaches_the_web_schema():
    pytest.importorskip("fastapi")
    from pydantic import ValidationError

    from barkgen.web.routes_jobs import job_request_model, request_options

    model = job_request_model(DummyOptions)
    schema = model.model_json_schema()["properties"]
    assert "dummy_strength" in schema and "dummy_mode" in schema, "the web schema lacks the field"
    assert schema["dummy_strength"]["maximum"] == 2 and schema["dummy_mode"]["enum"] == ["soft", "hard"]
    request = model(exemplar_id=1, dummy_strength=1.25, dummy_mode="hard")
    values = request_options(request, DummyOptions, seed=4)
    options = DummyOptions(**values)
    assert (options.dummy_strength, options.dummy_mode, options.seed) == (1.25, "hard", 4)
    with pytest.raises(ValidationError):
        model(exemplar_id=1, dummy_strength=3.0)


def test_a_new_field_reaches_batch_specs():
    pytest.importorskip("yaml")
    from barkgen.batch.spec import _options

    options, _files = _options(
        "exemplar 1", {"dummy_strength": 2, "dummy_mode": "hard", "size": 64}, None, DummyOptions
    )
    assert isinstance(options, DummyOptions), "the batch spec lacks the options class"
    assert (options.dummy_strength, options.dummy_mode, options.size) == (2.0, "hard", (64, 64))
    with pytest.raises(InvalidInputError, match="exemplar 1: dummy_strength must be a number"):
        _options("exemplar 1", {"dummy_strength": "much"}, None, DummyOptions)


def test_the_analysis_key_follows_the_declared_fields():
    base = DummyOptions(size=64)
    assert analysis_key(base) != analysis_key(dataclasses.replace(base, dummy_strength=1.0))
    # fields not declared analysis=True share an analysis: the seed, the blend, the new mode
    for change in ({"seed": 3}, {"blend": "none"}, {"dummy_mode": "hard"}, {"tile": True}):
        assert analysis_key(base) == analysis_key(dataclasses.replace(base, **change))


def test_every_field_is_declared_and_its_choices_are_the_checks_own():
    """Every GenerateOptions field is an option (a plain field would reach no front end), and
    a text option's choices are exactly what the class accepts."""
    declared = {f.name for f in option_fields(GenerateOptions)}
    assert declared == {f.name for f in dataclasses.fields(GenerateOptions)}
    for field in option_fields(GenerateOptions):
        assert set(field.info.fronts) <= set(FRONT_ENDS)
        for choice in field.info.choices or ():
            GenerateOptions(**{field.name: choice})
        if field.info.choices:
            with pytest.raises(InvalidInputError):
                GenerateOptions(**{field.name: "not-a-choice"})


def test_defaults_read_back_through_each_front_ends_text():
    """A field's default, shown as its front ends show it and read back, is the default."""
    for field in option_fields(GenerateOptions):
        if field.default is not None:
            assert field.read(field.default_text) == field.default, field.name


def test_the_cli_flags_are_the_fields():
    """``barkgen generate --help`` lists one flag per CLI field of GenerateOptions."""
    from typer.testing import CliRunner

    from barkgen.cli.app import app

    text = CliRunner().invoke(app, ["generate", "--help"], terminal_width=200).output
    for field in option_fields(GenerateOptions, "cli"):
        assert field.flag in text, f"barkgen generate lacks {field.flag}"


def test_a_new_field_reaches_the_web_form():
    """``/api/options`` lists the field with what the page builds its control from (the page
    builds one for every option it has none of its own for: test_web_browser)."""
    pytest.importorskip("fastapi")
    from barkgen.web.routes_jobs import web_options

    fields = {f["name"]: f for f in web_options(_state(), DummyOptions)["fields"]}
    assert "dummy_strength" in fields and "dummy_mode" in fields, "/api/options lacks the field"
    strength, mode = fields["dummy_strength"], fields["dummy_mode"]
    assert (strength["kind"], strength["default"], strength["minimum"], strength["maximum"]) == ("float", 0.5, 0, 2)
    assert (mode["choices"], mode["group"], mode["help"]) == (["soft", "hard"], "advanced", "A test's text option.")


def _state():
    from barkgen.web.state import WebLimits

    class State:  # what web_options reads of the app's state
        limits = WebLimits()

    return State()


def _run_report(options) -> dict:
    """report.json's values for a run of ``options`` (the run's own findings stubbed)."""
    import types

    import numpy as np

    from barkgen.pipeline.report import run_report

    labels = np.zeros((8, 8), np.uint8)
    labels[4:] = 1
    label_result = types.SimpleNamespace(layer_order=None, references=None, resumed_level=None, label_map=labels)
    result = types.SimpleNamespace(extras={}, extra_wraps={}, orientation=None)
    photo = np.zeros((8, 8, 3), np.uint8)
    return run_report(
        photo, options, (False, False), labels, label_result, result, None, {"total": 1.0}, referenced=False
    )


def test_a_new_field_reaches_report_json():
    import json

    report = json.loads(json.dumps(_run_report(DummyOptions(size=64, dummy_strength=1.5))))
    assert (report["dummy_strength"], report["dummy_mode"]) == (1.5, "soft"), "report.json lacks the field"


def test_report_json_has_every_option_under_its_key_and_keeps_its_old_keys():
    """Every GenerateOptions field is reported (``edges`` was missing when the keys were a hand
    list) but the run's budget, which moves no output; the keys readers know keep their names
    and values."""
    report = _run_report(GenerateOptions(size=(48, 64), edges=2, material=True, relief=1.5, width_m=0.4))
    for field in option_fields(GenerateOptions):
        if field.info.report == "":
            assert field.name in ("threads", "max_memory") and field.name not in report, field.name
        else:
            assert (field.info.report or field.name) in report, field.name
    assert report["edges"] == 2 and report["size"] == [64, 48] and report["k"] == 2
    assert report["exemplar_wrap_mode"] == "auto" and report["exemplar_wrap"] == [False, False]
    assert report["light_equalization"] == 1.0 and report["relief"] == 1.5 and report["width_m"] == 0.4
    assert report["material_options"]["relief"] == 1.5 and report["material_options"]["k"] == 3
    plain = _run_report(GenerateOptions(size=64))
    assert plain["relief"] is None and plain["width_m"] is None and plain["material_options"] is None
    assert plain["bilayer_options"] is None and plain["growth_options"] is None
    assert _run_report(GenerateOptions(size=64, model="bilayer", k=2))["bilayer_options"]["k"] == 2
    assert _run_report(GenerateOptions(size=64, structure="cracks"))["growth_options"]["max_levels"] == 64


def _material_options(monkeypatch, tmp_path, args: list[str]):
    """The options ``barkgen material`` makes of ``args`` with DummyMaterialOptions as its class."""
    import typer
    from typer.testing import CliRunner

    import barkgen.material
    from barkgen.cli import material as material_module
    from barkgen.cli._options import with_options

    command = with_options(DummyMaterialOptions, after="exr_height")(material_module.material_command.bare)

    def capture(photo, options, **kwargs):
        raise Captured(options)

    monkeypatch.setattr(barkgen.material, "make_material", capture)
    app = typer.Typer()
    app.command()(command)
    app.command("other")(lambda: None)
    result = CliRunner().invoke(app, ["material-command", "-o", str(tmp_path / "set"), "-q", *args])
    assert isinstance(result.exception, Captured), f"the CLI lacks an option of the options class: {result.output}"
    return result.exception.args[0]


def test_a_new_material_field_reaches_the_material_command_and_its_report(monkeypatch, tmp_path):
    options = _material_options(monkeypatch, tmp_path, ["--dummy-gloss", "0.75", "--relief", "2", "--tile"])
    assert isinstance(options, DummyMaterialOptions)
    assert (options.dummy_gloss, options.relief, options.exemplar_wrap) == (0.75, 2.0, "yes")
    assert _material_options(monkeypatch, tmp_path, []).dummy_gloss == 0.25
    assert option_values(options)["dummy_gloss"] == 0.75  # (report.json's material_options)
    with pytest.raises(InvalidInputError, match="dummy gloss must be between 0 and 1"):
        DummyMaterialOptions(dummy_gloss=3.0)


def test_a_commands_own_parameter_named_like_a_field_takes_its_flag():
    """option_flags: ``synth``'s ``--size``, ``--seed``, ``--exemplar-wraps`` are GenerateOptions'
    fields (help, range, reading, checks), ``--threads`` SynthesisConfig's."""
    import typer
    from typer.testing import CliRunner

    from barkgen.cli._options import option_flags

    got = {}

    @option_flags(SynthesisConfig, GenerateOptions)
    def command(*, size: tuple[int, int], seed: int, threads: int | None, strategy: str = "engine") -> None:
        got.update(size=size, seed=seed, threads=threads, strategy=strategy)

    app = typer.Typer()
    app.command()(command)
    app.command("other")(lambda: None)
    runner = CliRunner()
    assert runner.invoke(app, ["command", "--size", "64x32", "--seed", "5", "--threads", "2"]).exit_code == 0
    assert got == {"size": (32, 64), "seed": 5, "threads": 2, "strategy": "engine"}
    import inspect
    import typing

    params = inspect.signature(command).parameters  # what typer reads
    size_flag = typing.get_args(params["size"].annotation)[1]
    assert size_flag.help.startswith("Output size WIDTHxHEIGHT.") and params["strategy"].default == "engine"
    bad = runner.invoke(app, ["command", "--strategy", "bogus"])
    assert isinstance(bad.exception, InvalidInputError) and "strategy" in str(bad.exception)


@pytest.mark.parametrize("options_class", OPTIONS_CLASSES, ids=lambda c: c.__name__)
def test_every_options_class_declares_every_field_with_a_checked_range(options_class):
    """Each options class declares every field with option(); each field's default is within
    its declared range and choices, a value outside is refused in one line, and a default read
    back through its front ends' text is the default."""
    assert {f.name for f in option_fields(options_class)} == {f.name for f in dataclasses.fields(options_class)}
    check_options(options_class())
    for field in option_fields(options_class):
        assert set(field.info.fronts) <= set(FRONT_ENDS) and field.info.help, field.name
        if field.default is not None and field.info.text is not None:
            assert field.read(field.default_text) == field.default, field.name
        outside = None
        if field.info.maximum is not None and field.info.kind in (int, float):
            outside = field.info.maximum + 1
        elif field.info.choices:
            outside = "not-a-choice"
        if outside is not None:
            with pytest.raises(InvalidInputError):
                options_class(**{field.name: outside})
