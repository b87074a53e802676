"""A command's flags built from options classes (:mod:`barkgen._shared.options`): each field
that the CLI offers becomes one ``--flag`` with the field's help, default and range, so a new
option needs no edit here.

Two ways, which a command may combine:

- :func:`with_options`: every CLI field of a class is a flag, and the command receives the
  options object made from them (``generate``, ``tree``, ``material``, ``bilayer analyze``);
- :func:`option_flags`: the command's own parameters that name a field of one of the classes
  and carry no ``typer`` annotation take that field's flag, help and range (and its default
  unless the command gives one), read and checked by the class (``synth``'s ``--size``,
  ``--seed`` and ``--threads``: the canvas and budget flags a command shares with ``generate``).
"""

from __future__ import annotations

import dataclasses
import functools
import inspect
import typing
from collections.abc import Callable
from typing import Annotated, Any, Optional

import typer

from barkgen._shared.options import OptionField, option_fields


def _parameter(field: OptionField, default: Any = inspect.Parameter.empty) -> inspect.Parameter:
    """The typer parameter of ``field``: its flag, help, range; ``default`` (front-end text) in
    place of the field's own."""
    info = field.info
    shown = field.default_text if default is inspect.Parameter.empty else default
    kind = Optional[info.kind] if shown is None else info.kind  # noqa: UP045 (typer)
    extra: dict[str, Any] = {}
    if info.metavar is not None:
        extra["metavar"] = info.metavar
    elif info.choices is not None:  # (checked by the options class: its one-line error)
        extra["metavar"] = "{" + ",".join(info.choices) + "}"
    if info.kind in (int, float):
        extra.update(min=info.minimum, max=info.maximum)
    help_text = info.help if shown is None or info.kind is bool else f"{info.help} [default: {shown}]"
    if info.kind is bool and "/" in field.flag:
        help_text = f"{info.help} [default: {field.flag.split('/')[0 if shown else 1].strip().lstrip('-')}]"
    flag = typer.Option(field.flag, help=help_text, show_default=False, **extra)
    return inspect.Parameter(
        field.name, inspect.Parameter.KEYWORD_ONLY, annotation=Annotated[kind, flag], default=shown
    )


def _typer_signature(run: Callable, command: Callable, params: list[inspect.Parameter]) -> Callable:
    # typer reads this signature (keyword-only: click passes every value by name), not the
    # command's own
    run.__signature__ = inspect.Signature(  # type: ignore[attr-defined]
        [p.replace(kind=inspect.Parameter.KEYWORD_ONLY) for p in params]
    )
    run.__annotations__ = {}
    del run.__wrapped__  # type: ignore[attr-defined]
    run.bare = getattr(command, "bare", command)  # type: ignore[attr-defined]  # (for another options class)
    return run


def with_options(
    options_class: type, *, after: int | str = 2, into: str = "options", base: Any = None
) -> Callable[[Callable], Callable]:
    """Give a command the CLI's fields of ``options_class`` as flags.

    The command takes an ``into`` keyword (an ``options_class``, made from the flags) besides
    its own parameters; the flags are listed after its first ``after`` parameters (its
    arguments and ``-o``), or after the one named ``after``. With ``base`` (an instance), the
    flags' defaults are its values and the object is ``base`` with the flags' values. An
    invalid value is the class's own one-line error.
    """

    def decorate(command: Callable) -> Callable:
        fields = list(option_fields(options_class, "cli"))
        own = [p for p in inspect.signature(command, eval_str=True).parameters.values() if p.name != into]
        clash = {p.name for p in own} & {f.name for f in fields}
        if clash:
            raise TypeError(f"{command.__name__} declares {sorted(clash)}, which are options' fields")
        at = after if isinstance(after, int) else [p.name for p in own].index(after) + 1
        defaults = (
            {
                f.name: f.json_value(getattr(base, f.name))
                if f.info.text is None
                else f.info.text(getattr(base, f.name))
                for f in fields
            }
            if base is not None
            else {}
        )
        params = own[:at] + [_parameter(f, defaults.get(f.name, inspect.Parameter.empty)) for f in fields] + own[at:]

        @functools.wraps(command)
        def run(**values: Any) -> Any:
            given = {f.name: f.read(values.pop(f.name)) for f in fields}
            options = options_class(**given) if base is None else dataclasses.replace(base, **given)
            return command(**values, **{into: options})

        return _typer_signature(run, command, params)

    return decorate


def _is_typer(annotation: Any) -> bool:
    """The parameter says its own flag or argument (``Annotated[..., typer.Option(...)]``)."""
    return typing.get_origin(annotation) is Annotated


def option_flags(*options_classes: type) -> Callable[[Callable], Callable]:
    """Give the command's parameters that name a CLI field of one of ``options_classes`` (the
    first that has it) and carry no ``typer`` annotation that field's flag, help and range; the
    command's default, if it gives one, in place of the field's. The values are read and checked
    by the classes (each made with the fields it gave) and passed as the fields' values."""

    def decorate(command: Callable) -> Callable:
        own = list(inspect.signature(command, eval_str=True).parameters.values())
        taken: dict[str, tuple[type, OptionField]] = {}
        for options_class in reversed(options_classes):
            taken.update({f.name: (options_class, f) for f in option_fields(options_class, "cli")})
        mine = {p.name: taken[p.name] for p in own if p.name in taken and not _is_typer(p.annotation)}
        loose = [p.name for p in own if not _is_typer(p.annotation) and p.name not in mine]
        if loose:
            raise TypeError(f"{command.__name__}: {loose} are neither typer parameters nor options' fields")
        params = [_parameter(mine[p.name][1], p.default) if p.name in mine else p for p in own]

        @functools.wraps(command)
        def run(**values: Any) -> Any:
            for options_class in options_classes:
                names = [n for n, (c, _f) in mine.items() if c is options_class]
                if names:
                    made = options_class(**{n: mine[n][1].read(values[n]) for n in names})
                    values.update({n: getattr(made, n) for n in names})
            return command(**values)

        return _typer_signature(run, command, params)

    return decorate
