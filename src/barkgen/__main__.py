"""``python -m barkgen``: same as the ``barkgen`` command."""

from barkgen.cli import main

main()
