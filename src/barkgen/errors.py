"""Errors that barkgen reports to the user as one clear line (never a traceback)."""

from __future__ import annotations


class BarkgenError(Exception):
    """Base class of every error caused by the user's input or environment.

    Front ends print ``str(error)`` on one line and exit with status 2.
    """


class ImageReadError(BarkgenError):
    """An input file is missing, empty, truncated or not an image."""


class ImageTooLargeError(ImageReadError):
    """An input image has more pixels (or bytes) than the limit it is read under."""


class InvalidInputError(BarkgenError):
    """A parameter or an input array is out of range or inconsistent."""


class MemoryBudgetError(BarkgenError):
    """The estimated memory of a job exceeds the allowed budget."""


class MissingExtraError(BarkgenError):
    """A front end or format needs an optional extra that is not installed
    (``pip install 'barkgen[EXTRA]'``)."""
