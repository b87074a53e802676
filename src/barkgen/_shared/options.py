"""One source for every option of an options class: its default, range, help text, the front ends
that offer it, and how each reads it from text.

An options dataclass (:class:`barkgen.pipeline.GenerateOptions`,
:class:`barkgen.material.MaterialOptions`, :class:`barkgen.bilayer.AnalysisOptions` and
:class:`~barkgen.bilayer.SynthesisOptions`, :class:`barkgen.branching.GrowOptions`,
:class:`barkgen.synth.SynthesisConfig`) declares each field with :func:`option`; the CLI's flags,
the web API's schema and form (``/api/options``, :func:`option_schema`), batch specs and
``report.json`` (:func:`option_values`) are built from the fields' :class:`OptionInfo`
(``barkgen.cli``, ``barkgen.web``, ``barkgen.batch``, ``barkgen.pipeline.report``), so adding an
option is one field and nothing else. Each class checks its fields' declared ranges and choices
(:func:`check_options`) and its cross-field rules in its ``__post_init__``, where every front end
meets them.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from barkgen.errors import InvalidInputError

#: every front end that builds its options from the fields
FRONT_ENDS = ("cli", "web", "batch")


@dataclass(frozen=True)
class OptionInfo:
    """What a front end needs to offer one option.

    Attributes
    ----------
    help : str
        One or two sentences for ``--help``, the web schema and the docs.
    kind : type
        What the front ends read: ``bool``, ``int``, ``float`` or ``str`` (text that ``parse``
        turns into the field's value, e.g. ``"512x384"`` for a size).
    flag : str, optional
        The CLI flag (default: ``--`` and the field's name with dashes).
    choices : tuple of str, optional
        The values a text option may take.
    minimum, maximum : float, optional
        The range of a number (also checked by the class itself).
    parse : callable, optional
        Text -> the field's value (``kind`` is ``str``).
    text : callable, optional
        The field's default -> the text a front end shows (the inverse of ``parse``).
    fronts : tuple of str
        The front ends that offer it (:data:`FRONT_ENDS`); a server-side limit (threads,
        memory) is not the web's to set.
    analysis : bool
        The photo's analysis depends on it (:func:`barkgen.pipeline.analysis_key`).
    group : str
        The section of the web form that shows it (``""``: the main one).
    needs : str, optional
        The boolean option it applies under (``"material"``): the web form disables it while
        that one is off, and ``report.json`` says ``null`` for it.
    report : str, optional
        Its key in ``report.json`` (default: the field's name; ``""``: not reported).
    metavar : str, optional
        What ``--help`` shows for its value (default: the choices, or the kind).
    """

    help: str
    kind: type = str
    flag: str | None = None
    choices: tuple[str, ...] | None = None
    minimum: float | None = None
    maximum: float | None = None
    parse: Callable[[str], Any] | None = None
    text: Callable[[Any], str] | None = None
    fronts: tuple[str, ...] = FRONT_ENDS
    analysis: bool = False
    group: str = ""
    needs: str | None = None
    report: str | None = None
    metavar: str | None = None

    def __post_init__(self) -> None:
        unknown = set(self.fronts) - set(FRONT_ENDS)
        if unknown:
            raise ValueError(f"unknown front ends {sorted(unknown)}; known: {FRONT_ENDS}")
        if self.kind not in (bool, int, float, str):
            raise ValueError(f"an option's kind is bool, int, float or str, not {self.kind!r}")


def option(
    default: Any = dataclasses.MISSING, help: str = "", *, default_factory: Any = dataclasses.MISSING, **info: Any
) -> Any:
    """A dataclass field with its :class:`OptionInfo` (keyword arguments as its attributes);
    ``default_factory`` for a mutable default (an option no front end offers, ``fronts=()``)."""
    if not help:
        raise ValueError("an option says what it does (help)")
    return dataclasses.field(
        default=default, default_factory=default_factory, metadata={"option": OptionInfo(help=help, **info)}
    )


@dataclass(frozen=True)
class OptionField:
    """One field of an options class as a front end sees it."""

    name: str
    default: Any
    info: OptionInfo

    @property
    def flag(self) -> str:
        return self.info.flag or "--" + self.name.replace("_", "-")

    @property
    def default_text(self) -> Any:
        """The default as the front end's ``kind`` shows it (``None`` stays ``None``)."""
        if self.default is None or self.info.text is None:
            return self.default
        return self.info.text(self.default)

    def read(self, value: Any) -> Any:
        """A front end's value (of ``kind``, or None) -> the field's value."""
        if value is None or self.info.parse is None:
            return value
        return self.info.parse(value)

    def check(self, value: Any) -> None:
        """The declared range and choices; one line otherwise (a value of another type, such
        as a wrap given as ``(rows, columns)``, is its class's to check)."""
        info, name = self.info, self.name.replace("_", " ")
        if value is None:
            return
        if info.choices is not None and isinstance(value, str) and value not in info.choices:
            raise InvalidInputError(f"{name} must be one of {', '.join(info.choices)}, not {value!r}")
        if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
            return
        if info.kind in (int, float) and not np.isfinite(value):
            raise InvalidInputError(f"{name} must be a finite number, not {value}")
        low, high = info.minimum, info.maximum
        if (low is not None and value < low) or (high is not None and value > high):
            span = (
                f"between {low:g} and {high:g}"
                if low is not None and high is not None
                else (f">= {low:g}" if low is not None else f"<= {high:g}")
            )
            raise InvalidInputError(f"{name} must be {span}, not {value:g}")

    def json_value(self, value: Any) -> Any:
        """``value`` as JSON holds it: a number, text, a list, or the front ends' text."""
        if value is None or isinstance(value, (bool, str)):
            return value
        if isinstance(value, (int, np.integer)):
            return int(value)
        if isinstance(value, (float, np.floating)):
            return float(value)
        if isinstance(value, (tuple, list)):
            return [self.json_value(v) for v in value]
        if self.info.text is not None:
            return self.info.text(value)
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            return {f.name: self.json_value(getattr(value, f.name)) for f in dataclasses.fields(value)}
        return str(value)


def option_fields(options_class: type, front: str | None = None) -> Iterator[OptionField]:
    """The fields of ``options_class`` declared with :func:`option`, in order; with ``front``,
    those that front end offers."""
    for f in dataclasses.fields(options_class):
        info = f.metadata.get("option")
        if info is None or (front is not None and front not in info.fronts):
            continue
        default = f.default_factory() if f.default is dataclasses.MISSING and callable(f.default_factory) else f.default
        yield OptionField(f.name, default, info)


def check_options(options: Any) -> None:
    """Every declared field of ``options`` within its range and choices (:meth:`OptionField.check`);
    a class's ``__post_init__`` calls it after its own checks and before its cross-field rules."""
    for field in option_fields(type(options)):
        field.check(getattr(options, field.name))


def option_values(options: Any) -> dict[str, Any]:
    """The JSON-ready values of every declared field of ``options``, under its report key
    (:attr:`OptionInfo.report`); an option whose ``needs`` is off is ``None`` (``report.json``
    is written from it, :func:`barkgen.pipeline.report.run_report`)."""
    out: dict[str, Any] = {}
    for field in option_fields(type(options)):
        key = field.name if field.info.report is None else field.info.report
        if not key:
            continue
        value = getattr(options, field.name)
        off = field.info.needs is not None and not getattr(options, field.info.needs)
        out[key] = None if off else field.json_value(value)
    return out


def option_schema(options_class: type, front: str, defaults: Mapping[str, Any] | None = None) -> list[dict]:
    """What a form needs to show each field ``front`` offers: name, kind, default (as the front
    shows it; ``defaults`` in place of a field's own), range, choices, help, group and the
    option it needs (the web's ``/api/options``)."""
    defaults = defaults or {}
    return [
        {
            "name": f.name,
            "kind": f.info.kind.__name__,
            "default": defaults[f.name] if f.name in defaults else f.json_value(f.default_text),
            "minimum": f.info.minimum,
            "maximum": f.info.maximum,
            "choices": list(f.info.choices) if f.info.choices else None,
            "help": f.info.help,
            "group": f.info.group,
            "needs": f.info.needs,
        }
        for f in option_fields(options_class, front)
    ]
