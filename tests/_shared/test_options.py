"""One source for every option: GenerateOptions' fields (barkgen._shared.options) make the CLI's
flags, the web API's request schema and a batch spec's keys. Adding an option is the field (and
nothing else): a dummy field added here reaches every front end, or the test names the one that
lacks it."""

from __future__ import annotations

import dataclasses

import pytest

from barkgen._shared.options import FRONT_ENDS, option, option_fields
from barkgen.errors import InvalidInputError
from barkgen.pipeline import GenerateOptions, analysis_key


@dataclasses.dataclass(frozen=True)
class DummyOptions(GenerateOptions):
    """GenerateOptions with one more option, declared as every option is."""

    dummy_strength: float = option(0.5, "A test's option.", kind=float, minimum=0, maximum=2, analysis=True)
    dummy_mode: str = option("soft", "A test's text option.", choices=("soft", "hard"))


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
