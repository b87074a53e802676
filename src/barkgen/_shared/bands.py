"""Long kernels run a band of rows per call, so that Ctrl-C is heard within a second.

A numba kernel, like an OpenCV or faiss call, holds the interpreter for as long as it runs:
Python's signal handler (and with it Ctrl-C's ``KeyboardInterrupt``) waits until the call
returns, and so does every other thread of the process. A kernel whose call grows with the
image (a bilateral filter over a photo, a search over a 4096² level) is therefore called
once per band of rows, each band about :data:`BAND_STEPS` steps of its inner loop: about
0.1 s on two cores, the price of a few hundred calls' overhead on a whole image. Every row
is computed from the kernel's inputs alone, so the bands give the bytes one call would.
"""

from __future__ import annotations

#: inner-loop steps per call (a step: one tap of a filter, one candidate's distance, ...);
#: about 0.1 s on two cores (a joint bilateral tap of 8 guide and 3 colour channels: 0.1 s
#: for 110 million)
BAND_STEPS = 100_000_000
#: a numpy expression's step (one element of one operation, with its temporaries) costs about
#: this many of a kernel's: work done by numpy counts its element operations times this
NUMPY_STEP = 10


def row_bands(height: int, steps_per_row: float, steps: int = BAND_STEPS) -> list[tuple[int, int]]:
    """``(start, stop)`` bands covering ``range(height)`` in order, each of at most ``steps``
    inner-loop steps at ``steps_per_row`` (at least one row).

    Parameters
    ----------
    height : int
        Rows to cover.
    steps_per_row : float
        The kernel's inner-loop steps for one row.
    steps : int
        Steps per band.

    Returns
    -------
    list of tuple of int
    """
    rows = max(1, int(steps // max(1.0, float(steps_per_row))))
    return [(start, min(height, start + rows)) for start in range(0, height, rows)]
