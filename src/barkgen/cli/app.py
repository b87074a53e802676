"""The ``barkgen`` command line: a thin front end over the public API.

This is the root: the typer app and its ``--version``, the translation of every failure into one
line on stderr (:func:`user_errors`) and the registration of the command groups, one module
each: :mod:`.synth` (synth, tbn, apply-reference), :mod:`.labels` (labels, textons, merge),
:mod:`.shapes`, :mod:`.generate` (generate, batch), :mod:`.material` (material, preview,
export-glb), :mod:`.serve`, :mod:`.warmup` (warm-up), and the sub-commands of
:mod:`.bilayer`, :mod:`.library`, :mod:`.branches` and :mod:`.cache`. What they share is in :mod:`._common`.
"""

from __future__ import annotations

import functools
import logging
import sys
import warnings
from collections.abc import Callable
from typing import Annotated, Any, Optional, TypeVar

import typer

import barkgen.cli.bilayer as bilayer
import barkgen.cli.branches as branches
import barkgen.cli.cache as cache
import barkgen.cli.evaluate as evaluate
import barkgen.cli.generate as generate
import barkgen.cli.labels as labels
import barkgen.cli.library as library
import barkgen.cli.material as material
import barkgen.cli.serve as serve
import barkgen.cli.shapes as shapes
import barkgen.cli.synth as synth
import barkgen.cli.tree as tree
import barkgen.cli.warmup as warmup
from barkgen._shared.checks import OUTPUT_PIXEL_LIMIT
from barkgen.cli._common import MAX_INPUT_PIXELS, fail, guard_paths
from barkgen.errors import BarkgenError

F = TypeVar("F", bound=Callable[..., None])

#: the commands of ``barkgen --help``, in its order (the groups follow them)
TOP_LEVEL = (
    "synth",
    "tbn",
    "labels",
    "textons",
    "merge",
    "shapes",
    "generate",
    "material",
    "preview",
    "export-glb",
    "apply-reference",
    "batch",
    "tree",
    "serve",
    "warm-up",
    "evaluate",
)
#: the modules that give those commands
COMMAND_MODULES = (synth, labels, shapes, generate, tree, material, serve, warmup, evaluate)
#: the groups of sub-commands (``barkgen bilayer analyze`` ...), in the order of ``--help``
GROUPS = (("bilayer", bilayer), ("library", library), ("branches", branches), ("cache", cache))

_TYPER_SETTINGS: dict[str, Any] = dict(
    add_completion=False, no_args_is_help=True, pretty_exceptions_enable=False, rich_markup_mode=None
)

app = typer.Typer(
    name="barkgen",
    help="Turn one photograph of tree bark into unlimited new, seamless, varied bark.",
    **_TYPER_SETTINGS,
)


def _one_line_warning(message, category, filename, lineno, file=None, line=None) -> None:
    print(f"barkgen: warning: {message}", file=sys.stderr)


class _NoteLine(logging.Handler):
    """The library's word that its kernels compile (the ``barkgen.kernels`` logger, once per
    process on a cold cache) as one line on stderr like the others, where the progress bar
    would show: on a terminal, without ``--quiet``."""

    def emit(self, record: logging.LogRecord) -> None:
        print(f"barkgen: note: {record.getMessage()}", file=sys.stderr)


_NOTES = _NoteLine()


def _show_notes(show: bool) -> None:
    logger = logging.getLogger("barkgen.kernels")
    if _NOTES not in logger.handlers:
        logger.addHandler(_NOTES)
    _NOTES.setLevel(logging.NOTSET if show else logging.CRITICAL + 1)


def user_errors(func: F) -> F:
    """Run a command so that every failure is one line on stderr, never a traceback:
    user errors exit with status 2, interruptions with 130, anything unexpected with 1."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        warnings.showwarning = _one_line_warning
        _show_notes(not kwargs.get("quiet") and getattr(sys.stderr, "isatty", bool)())
        forget = None
        try:
            forget = guard_paths(kwargs)  # no output is an input; every output folder writable
            return func(*args, **kwargs)
        except (typer.Exit, typer.Abort):
            raise
        except BarkgenError as exc:
            raise fail(str(exc)) from None
        except MemoryError:
            raise fail("out of memory (try a smaller --size or fewer --extra maps)") from None
        except OSError as exc:
            where = f" ({exc.filename})" if getattr(exc, "filename", None) else ""
            raise fail(f"{exc.strerror or exc}{where}") from None
        except KeyboardInterrupt:
            raise fail("interrupted", 130) from None
        except Exception as exc:  # noqa: BLE001 - last resort: still one line, no traceback
            raise fail(f"internal error: {type(exc).__name__}: {exc}", 1) from None
        finally:
            if forget is not None:
                forget()

    return wrapper  # type: ignore[return-value]


@app.callback(invoke_without_command=True)
def _root(
    version: Annotated[bool, typer.Option("--version", help="Print the version and exit.")] = False,
    max_pixels: Annotated[
        Optional[int],
        typer.Option(
            "--max-pixels",
            min=1,
            help="Largest input image any command reads and largest output it "
            "makes, in pixels (default 50000000 in, 8192x8192 out; generate analyses at most "
            "50000000 whatever this says).",
        ),
    ] = None,
) -> None:
    MAX_INPUT_PIXELS.set(max_pixels)
    OUTPUT_PIXEL_LIMIT.set(max_pixels)
    if version:
        from barkgen._version import __version__

        typer.echo(f"barkgen {__version__}")
        raise typer.Exit()


def _register() -> None:
    """Every command under :func:`user_errors`: the top-level ones in :data:`TOP_LEVEL`'s order,
    then one sub-app per group."""
    commands = dict(command for module in COMMAND_MODULES for command in module.COMMANDS)
    if set(commands) != set(TOP_LEVEL):
        raise RuntimeError(
            f"commands missing from TOP_LEVEL or from their modules: {sorted(set(commands) ^ set(TOP_LEVEL))}"
        )
    for name in TOP_LEVEL:
        app.command(name)(user_errors(commands[name]))
    for group_name, module in GROUPS:
        group = typer.Typer(name=group_name, help=module.HELP, **_TYPER_SETTINGS)
        for name, command in module.COMMANDS:
            group.command(name)(user_errors(command))
        app.add_typer(group, name=group_name)


_register()
