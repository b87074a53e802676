"""The library's errors."""

from __future__ import annotations

from barkgen.errors import BarkgenError


class LibraryError(BarkgenError):
    """The library folder or database cannot be used (a :class:`~barkgen.errors.BarkgenError`)."""


class NotFoundError(LibraryError):
    """No exemplar or result has the id asked for (a :class:`LibraryError`)."""


class _ReadOnly(Exception):
    """The database cannot be written (raised while migrating; the library is then read-only)."""
