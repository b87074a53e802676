"""The options of growth (:func:`barkgen.branching.grow_structure`, sibbing2010 §4.5's stopping
rules) and its memory budget, checked before any work."""

from __future__ import annotations

from dataclasses import dataclass

from barkgen._shared.memory import check_budget_value, check_memory_budget, parse_memory
from barkgen._shared.options import check_options, option
from barkgen.errors import InvalidInputError

#: the regulariser of growth's density scaling ``Q** = Q* / (D + eps)``: ``1 / eps`` bounds it (§4.4)
EPSILON = 1e-3


@dataclass(frozen=True)
class GrowOptions:
    """Stopping rules and space-colonisation parameters of :func:`grow_structure` (sibbing2010
    §4.4-4.5), checked once when made."""

    total_length: float | None = option(
        None,
        "Total branch length to grow in px (default: the source's length per pixel times the output area).",
        kind=float,
        flag="--length",
    )
    max_levels: int = option(64, "Maximum branch generations.", kind=int, flag="--levels")
    rho: float | None = option(
        None,
        "Density spread in px (default: learned from the source).",
        kind=float,
        minimum=0.5,
        maximum=1000,
        fronts=(),
    )
    fill: float = option(
        2.0, "Stop adding roots when no pixel is farther than fill x rho.", kind=float, minimum=0, fronts=()
    )
    max_branches: int = option(20000, "Most branches grown.", kind=int, minimum=1, fronts=())
    max_memory: int | None = option(
        None,
        "Refuse jobs estimated to need more memory than this, e.g. 8G (default: what the machine has free).",
        parse=parse_memory,
    )

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> GrowOptions:
        if self.total_length is not None and not 0 < self.total_length <= 1e8:
            raise InvalidInputError(f"total length must be in (0, 1e8] pixels, got {self.total_length}")
        if not 0 <= self.max_levels <= 1000:
            raise InvalidInputError(f"levels must be in 0..1000, got {self.max_levels}")
        if self.rho is not None and not 0.5 <= self.rho <= 1000:
            raise InvalidInputError(f"rho must be in [0.5, 1000] pixels, got {self.rho}")
        check_budget_value(self.max_memory)
        check_options(self)
        return self


#: bytes per output pixel of growth's maps (distance, density, nearest branch, vertex and
#: tangent: 5 x 4 bytes) and the guide; measured peak RSS 5.3 GiB at 16384x16384 (5.2 estimated)
GROW_BYTES_PER_PIXEL = 20
GROW_BASE_BYTES = 200 * 2**20


def estimate_grow_memory(size: tuple[int, int], guide: bool = False) -> int:
    """Estimated peak bytes of :func:`grow_structure` at ``size = (width, height)``."""
    return GROW_BASE_BYTES + int(size[0]) * int(size[1]) * (GROW_BYTES_PER_PIXEL + (4 if guide else 0))


def check_grow_size(size: tuple[int, int], options: GrowOptions, guide: bool = False) -> None:
    """Refuse, before any work, a growth size out of range (8 to 16384 px a side) or estimated
    above ``options.max_memory`` (front ends call it before fitting the model)."""
    w, h = int(size[0]), int(size[1])
    if not (8 <= w <= 16384 and 8 <= h <= 16384):
        raise InvalidInputError(f"size must be between 8x8 and 16384x16384, got {w}x{h}")
    check_memory_budget(estimate_grow_memory((w, h), guide), options.max_memory, f"growing a structure of {w}x{h}")
