"""The memory budget every job is checked against before it starts.

A job's peak memory is estimated from its sizes alone (each stage's estimate lives beside its
code and was measured as peak RSS); :func:`check_memory_budget` compares it with the budget
and refuses the job in one line. The default budget, ``None``, is what the machine has free
when the job starts (psutil's ``available``: free memory plus what the kernel can reclaim).
"""

from __future__ import annotations

import functools
import re

from barkgen.errors import InvalidInputError, MemoryBudgetError

_MEM_RE = re.compile(r"^\s*(\d+(?:\.\d+)?)\s*([kKmMgGtT]?)i?[bB]?\s*$")

#: the interpreter, numpy, numba's and faiss' libraries before any array is made (peak RSS of
#: the smallest jobs, 2026-12-02)
BASE_BYTES = 250 * 2**20


def available_memory() -> int:
    """Bytes the machine can give a new job now (psutil's ``virtual_memory().available``)."""
    import psutil

    return int(psutil.virtual_memory().available)


def check_budget_value(max_memory: int | None, what: str = "max_memory") -> None:
    """A budget is ``None`` (what the machine has free) or a positive byte count."""
    if max_memory is None:
        return
    if isinstance(max_memory, bool) or not isinstance(max_memory, int) or max_memory <= 0:
        raise InvalidInputError(
            f"{what} must be a positive number of bytes (or None: what the machine has free), not {max_memory!r}"
        )


def format_bytes(n: int) -> str:
    """``n`` bytes for a person: GiB with one decimal from 1 GiB, MiB (whole) below, KiB below
    that (a 10 MiB budget reads "10 MiB", not "0.0 GiB")."""
    if n >= 2**30:
        return f"{n / 2**30:.1f} GiB"
    if n >= 2**20:
        return f"{n / 2**20:.0f} MiB"
    return f"{max(n, 0) / 2**10:.0f} KiB"


def check_memory_budget(need: int, max_memory: int | None, job: str) -> int:
    """Refuse ``job`` (e.g. ``"output 4096x4096"``) before any work when its estimated peak
    ``need`` (bytes) exceeds ``max_memory`` (``None``: what the machine has free now).

    Returns
    -------
    int
        ``need``.

    Raises
    ------
    MemoryBudgetError
        One line: the estimate, the budget and how to raise it.
    """
    budget = available_memory() if max_memory is None else max_memory
    if need > budget:
        what = "the memory budget" if max_memory is not None else "the memory free on this machine"
        raise MemoryBudgetError(
            f"{job} needs about {format_bytes(need)}, more than {what} "
            f"({format_bytes(budget)}; set it with --max-memory)"
        )
    return need


def parse_memory(text: str | None) -> int | None:
    """``"8G"``, ``"512M"``, ``"1.5GB"`` or a byte count -> bytes; None (what the machine has
    free) stays None."""
    if text is None:
        return None
    m = _MEM_RE.match(text)
    if not m:
        raise InvalidInputError(f"invalid memory amount {text!r}: use e.g. 8G or 512M")
    value = float(m.group(1)) * 1024 ** " KMGT".index((m.group(2) or " ").upper())
    if value <= 0:
        raise InvalidInputError(f"invalid memory amount {text!r}: must be positive")
    return int(value)


def give_back_freed_memory() -> None:
    """Hand the C heap's freed pages back to the system (glibc's ``malloc_trim``; elsewhere
    nothing). A run that frees a window's working arrays before the next window's are made
    otherwise keeps the freed pages of both: glibc serves arrays under its mmap threshold
    (which rises to 32 MiB as large blocks are freed) from a heap it seldom shrinks, so a 4096²
    windowed run's peak RSS stood 130-450 MiB over its live arrays (issue 69)."""
    trim = _malloc_trim()
    if trim is not None:
        trim(0)


@functools.cache
def _malloc_trim():
    """glibc's ``malloc_trim``, or None where the C library has none (macOS, Windows, musl)."""
    import ctypes
    import ctypes.util

    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name) if name else None
    except OSError:
        return None
    trim = getattr(libc, "malloc_trim", None)
    if trim is not None:
        trim.argtypes, trim.restype = [ctypes.c_size_t], ctypes.c_int
    return trim
