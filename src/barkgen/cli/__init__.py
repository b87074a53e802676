"""Command-line entry point of ``barkgen``.

User errors (:class:`barkgen.errors.BarkgenError`) become one line on stderr and exit status 2;
see :func:`barkgen.cli.app.user_errors`. So do the errors the command line's parser finds (an
unknown option, ``--seed -1``, a missing argument): ``barkgen: error: MESSAGE (see barkgen
COMMAND --help)``, not the parser's three-line usage.
"""

from __future__ import annotations

import os
import signal
import sys
from typing import Any, NoReturn


def _terminate(signum, frame) -> None:
    """SIGTERM (``kill``, a service manager, a batch scheduler) ends a run as Ctrl-C does: files
    half-staged are removed, nothing is left under a final name, exit status 130."""
    raise KeyboardInterrupt


def _leave(status: int) -> NoReturn:
    """Exit with ``status``. An interrupted run (130) ends at once: its files were cleaned up as
    the interrupt unwound, and what is left of the process holds nothing to keep, though it
    can take long to wind down (threads still computing, :func:`barkgen._shared.threads.worker_pool`;
    the analysis cache's write behind, whose temporary the next write removes; the libraries'
    thread pools and the interpreter's own teardown: 1-14 s beside a CPU-heavy job)."""
    if status == 130:
        import logging

        logging.shutdown()
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(130)
    sys.exit(status)


def main(argv: list[str] | None = None) -> NoReturn:
    """Run the ``barkgen`` CLI (exits the process with the command's status)."""
    from barkgen._shared.extras import require_extra
    from barkgen.errors import MissingExtraError

    try:
        require_extra("cli", "the barkgen command")
    except MissingExtraError as exc:
        print(f"barkgen: error: {exc}", file=sys.stderr)
        sys.exit(2)
    import typer

    from barkgen.cli.app import app

    try:
        signal.signal(signal.SIGTERM, _terminate)
    except ValueError:  # not the main thread (an embedding caller's): its own handlers stand
        pass

    # click's UsageError, whichever click typer runs on (its own copy, or click itself)
    usage_error: Any = next(c for c in typer.BadParameter.__mro__ if c.__name__ == "UsageError")
    try:
        status = app(args=argv, prog_name="barkgen", standalone_mode=False)
    except usage_error as exc:
        if type(exc).__name__ == "NoArgsIsHelpError":  # ``barkgen`` or a group alone: its help
            exc.show()
            sys.exit(exc.exit_code)
        where = exc.ctx.command_path if exc.ctx is not None else "barkgen"
        print(f"barkgen: error: {exc.format_message()} (see {where} --help)", file=sys.stderr)
        sys.exit(2)
    except typer.Abort:
        print("barkgen: error: interrupted", file=sys.stderr)
        _leave(130)
    _leave(status if isinstance(status, int) else 0)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
