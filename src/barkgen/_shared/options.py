"""One source for every option of an options class: its default, range, help text, the front ends
that offer it, and how each reads it from text.

An options dataclass (:class:`barkgen.pipeline.GenerateOptions`) declares each field with
:func:`option`; the CLI, the web API's schema and batch specs are built from the fields'
:class:`OptionInfo` (``barkgen.cli``, ``barkgen.web``, ``barkgen.batch``), so adding an option is
one field and nothing else. The cross-field rules live in the class's ``__post_init__``, where
every front end meets them.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

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

    def __post_init__(self) -> None:
        unknown = set(self.fronts) - set(FRONT_ENDS)
        if unknown:
            raise ValueError(f"unknown front ends {sorted(unknown)}; known: {FRONT_ENDS}")
        if self.kind not in (bool, int, float, str):
            raise ValueError(f"an option's kind is bool, int, float or str, not {self.kind!r}")


def option(default: Any, help: str, **info: Any) -> Any:
    """A dataclass field with its :class:`OptionInfo` (keyword arguments as its attributes)."""
    return dataclasses.field(default=default, metadata={"option": OptionInfo(help=help, **info)})


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


def option_fields(options_class: type, front: str | None = None) -> Iterator[OptionField]:
    """The fields of ``options_class`` declared with :func:`option`, in order; with ``front``,
    those that front end offers."""
    for f in dataclasses.fields(options_class):
        info = f.metadata.get("option")
        if info is None or (front is not None and front not in info.fronts):
            continue
        yield OptionField(f.name, f.default, info)
