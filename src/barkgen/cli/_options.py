"""A command's flags built from an options class (:mod:`barkgen._shared.options`): each field
that the CLI offers becomes one ``--flag`` with the field's help, default and range, and the
command receives the options object made from them, so a new option needs no edit here."""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable
from typing import Annotated, Any, Optional

import typer

from barkgen._shared.options import OptionField, option_fields


def _parameter(field: OptionField) -> inspect.Parameter:
    info = field.info
    kind = Optional[info.kind] if field.default is None else info.kind  # noqa: UP045 (typer)
    extra: dict[str, Any] = {}
    if info.choices is not None:  # (checked by the options class: its one-line error)
        extra["metavar"] = "{" + ",".join(info.choices) + "}"
    if info.kind in (int, float):
        extra.update(min=info.minimum, max=info.maximum)
    help_text = (
        info.help if field.default is None or info.kind is bool else f"{info.help} [default: {field.default_text}]"
    )
    flag = typer.Option(field.flag, help=help_text, show_default=False, **extra)
    return inspect.Parameter(
        field.name, inspect.Parameter.KEYWORD_ONLY, annotation=Annotated[kind, flag], default=field.default_text
    )


def with_options(options_class: type, *, after: int = 2) -> Callable[[Callable], Callable]:
    """Give a command the CLI's fields of ``options_class`` as flags.

    The command takes an ``options`` keyword (an ``options_class``, made from the flags) besides
    its own parameters; the flags are listed after its first ``after`` parameters (its arguments
    and ``-o``). An invalid value is the class's own one-line error.
    """

    def decorate(command: Callable) -> Callable:
        fields = list(option_fields(options_class, "cli"))
        own = [p for p in inspect.signature(command, eval_str=True).parameters.values() if p.name != "options"]
        clash = {p.name for p in own} & {f.name for f in fields}
        if clash:
            raise TypeError(f"{command.__name__} declares {sorted(clash)}, which are options' fields")
        params = own[:after] + [_parameter(f) for f in fields] + own[after:]

        @functools.wraps(command)
        def run(**values: Any) -> Any:
            options = options_class(**{f.name: f.read(values.pop(f.name)) for f in fields})
            return command(**values, options=options)

        # typer reads this signature (keyword-only: click passes every value by name), not the
        # command's own
        run.__signature__ = inspect.Signature(  # type: ignore[attr-defined]
            [p.replace(kind=inspect.Parameter.KEYWORD_ONLY) for p in params]
        )
        run.__annotations__ = {}
        del run.__wrapped__
        run.bare = command  # type: ignore[attr-defined]  # (for another options class)
        return run

    return decorate
