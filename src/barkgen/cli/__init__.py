"""Command-line entry point of ``barkgen``.

User errors (:class:`barkgen.errors.BarkgenError`) become one line on stderr and exit status 2;
see :func:`barkgen.cli.app.user_errors`.
"""

from __future__ import annotations

import sys


def main(argv: list[str] | None = None) -> None:
    """Run the ``barkgen`` CLI (exits the process with the command's status)."""
    from barkgen._shared.extras import require_extra
    from barkgen.errors import MissingExtraError

    try:
        require_extra("cli", "the barkgen command")
    except MissingExtraError as exc:
        print(f"barkgen: error: {exc}", file=sys.stderr)
        sys.exit(2)
    from barkgen.cli.app import app

    app(args=argv, prog_name="barkgen")


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
