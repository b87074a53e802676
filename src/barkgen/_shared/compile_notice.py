"""One line when barkgen's numba kernels compile: the first time a process compiles one.

The kernels are compiled on their first call and kept on disk (``cache=True``), so the first
run after an install spends about 30 s compiling, which looked like a hang. :func:`watch`
listens to numba's ``numba:compile`` event, which numba fires only when it really compiles a
function (a cache miss), never when it loads one from its cache: a warm cache costs nothing and
says nothing. The first compile of one of barkgen's cached kernels logs :data:`MESSAGE` as a
warning on the ``barkgen.kernels`` logger (a warning shows without any logging set up), once
per process. :func:`barkgen.warm_up` compiles on purpose, :func:`quiet`.

The synthesis' thread budget (every run of the solver and of the pipeline) and the package
face (``barkgen.synthesize`` and the other lazy names) call :func:`watch`; it registers the
listener once.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Iterator
from contextlib import contextmanager

log = logging.getLogger("barkgen.kernels")

MESSAGE = (
    "compiling barkgen's numba kernels (once per install, about 30 s); call "
    "barkgen.warm_up() (or run `barkgen warm-up`) ahead to do it up front"
)

_lock = threading.Lock()
_state = {"watching": False, "said": False, "quiet": 0}


def is_cached_kernel(dispatcher) -> bool:
    """True when ``dispatcher`` is one of barkgen's kernels that numba keeps on disk
    (``cache=True``): its ``numba:compile`` event means its cache missed. Helpers without a
    cache of their own (compiled into their callers) and other packages' functions are not."""
    from numba.core.caching import NullCache

    module = getattr(getattr(dispatcher, "py_func", None), "__module__", None) or ""
    cache = getattr(dispatcher, "_cache", None)
    return module.startswith("barkgen.") and cache is not None and not isinstance(cache, NullCache)


def _on_compile(dispatcher) -> None:
    if _state["said"] or _state["quiet"] or not is_cached_kernel(dispatcher):
        return
    _state["said"] = True
    log.warning(MESSAGE)


def watch() -> None:
    """Listen for the first compile of a barkgen kernel in this process (idempotent, cheap)."""
    if _state["watching"]:
        return
    with _lock:
        if _state["watching"]:
            return
        from numba.core import event

        class _Listener(event.Listener):
            def on_start(self, ev) -> None:
                _on_compile(ev.data["dispatcher"])

            def on_end(self, ev) -> None:
                pass

        event.register("numba:compile", _Listener())
        _state["watching"] = True


@contextmanager
def quiet() -> Iterator[None]:
    """No notice within the block (a warm-up compiles on purpose)."""
    with _lock:
        _state["quiet"] += 1
    try:
        yield
    finally:
        with _lock:
            _state["quiet"] -= 1
