"""The two objects a run hands down its stages instead of keyword lists: the :class:`Canvas` (what
the output is: its shape, whether it tiles, which axes of the photo wrap, the flow and scale
fields it follows, the pixels linked across an atlas's gutters) and the :class:`Budget` (how the
run may work: its seed, threads, memory, progress callback and analysis cache). Each is built
once, by the pipeline or a public function's front, and checked there; a stage reads what it
needs and passes the object on."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Callable

    ProgressCallback = Callable[[int, int], None]


@dataclass(frozen=True, eq=False)
class Canvas:
    """What the output is, shared by the label map, the texture and the material.

    Attributes
    ----------
    shape : (int, int)
        Output ``(height, width)``.
    tile : bool
        The output tiles (every neighbourhood wraps round its edges; mazzolini2012 §4.1).
    exemplar_wrap : (bool, bool), None or {"auto", "yes", "no"} or bool
        The photo's axes that wrap (rows, columns): its neighbourhoods are read across those
        edges (resolved once from ``"auto"``, :func:`barkgen.synth.resolve_exemplar_wrap`).
        None: not resolved yet, ``"auto"`` (the public function that reads the photo decides);
        a mode (``"auto"``, ``"yes"``, ``"no"``, a bool) is kept as given until then.
    flow, flow_scale : ndarray, optional
        ``(H, W)`` orientation (degrees) and scale fields the bark follows (mazzolini2012
        §3.1.3).
    links : OutputLinks, optional
        Output pixels that take the references of others (a texture atlas's gutters).
    oriented : OrientedExemplar, optional
        Along the flow fields, the atlas of the exemplar's turned copies to use (one another
        synthesis of the same fields shares, :func:`barkgen.synth.orient_exemplar`); else the
        solver makes the one the fields need.
    """

    shape: tuple[int, int]
    tile: bool = False
    exemplar_wrap: Any = None  # (bool, bool) once resolved; None or a mode before
    flow: np.ndarray | None = None
    flow_scale: np.ndarray | None = None
    links: Any = None
    oriented: Any = None

    def __post_init__(self) -> None:
        shape = (int(self.shape[0]), int(self.shape[1]))
        object.__setattr__(self, "shape", shape)
        object.__setattr__(self, "tile", bool(self.tile))
        if isinstance(self.exemplar_wrap, (tuple, list)):
            object.__setattr__(self, "exemplar_wrap", (bool(self.exemplar_wrap[0]), bool(self.exemplar_wrap[1])))

    @property
    def along(self) -> bool:
        """The bark follows a flow or scale field."""
        return self.flow is not None or self.flow_scale is not None

    @property
    def wrap_mode(self) -> str | bool | tuple[bool, bool]:
        """``exemplar_wrap`` as :func:`barkgen.synth.resolve_exemplar_wrap` reads it (None:
        ``"auto"``)."""
        return "auto" if self.exemplar_wrap is None else self.exemplar_wrap

    @property
    def wrap_axes(self) -> tuple[bool, bool]:
        """The output's axes that wrap (both when it tiles)."""
        return (self.tile, self.tile)

    def replace(self, **changes: Any) -> Canvas:
        """A copy with ``changes``."""
        return dataclasses.replace(self, **changes)


@dataclass(frozen=True, eq=False)
class Budget:
    """How a run may work; none of it changes the result but ``seed``.

    Attributes
    ----------
    seed : int
        Every random choice of the run flows from it.
    threads : int, optional
        Threads for the parallel stages (default: every core).
    max_memory : int, optional
        Bytes the run may use (default: what the machine has).
    progress : callable, optional
        ``progress(done, total)``.
    cache : AnalysisCache, optional
        The photo's analysis, shared by every seed.
    debug : callable, optional
        ``debug(name, image)`` receives the solver's intermediate images (uint8).
    """

    seed: int = 0
    threads: int | None = None
    max_memory: int | None = None
    progress: ProgressCallback | None = None
    cache: Any = None
    debug: Callable[[str, np.ndarray], None] | None = None

    def rng(self, offset: int = 0) -> np.random.Generator:
        """The run's generator (``offset`` picks an independent stream of the same seed)."""
        return np.random.default_rng(self.seed if offset == 0 else (self.seed, offset))

    def replace(self, **changes: Any) -> Budget:
        """A copy with ``changes``."""
        return dataclasses.replace(self, **changes)
