"""UDIM tiles: one large output written as a grid of tiles that Mari, Blender, Substance
Painter and Houdini load as one image (issue 69).

A tile's number is ``1001 + column + 10 * row`` (the Mari convention), its UV square
``[column, column + 1] x [row, row + 1]``. UV's ``v`` runs up, an image's rows down: the
output's top row of tiles is the highest UDIM row, its bottom row tiles 1001-1010. Each map of
the set is written once a tile, ``NAME_Color.1001.png``, ``NAME_Color.1002.png``, ... (the
number before the extension), and every tile continues into its neighbours because the output
is synthesized as one canvas and only cut into tiles when written.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from barkgen.errors import InvalidInputError

#: the first tile's number (UV square 0..1 x 0..1)
UDIM_FIRST = 1001
#: tiles along u: ten a UDIM row
UDIM_MAX_COLUMNS = 10
#: rows of tiles (1001 .. 1990)
UDIM_MAX_ROWS = 99
#: the placeholder Blender, Mari and MaterialX read in a tiled image's file name
UDIM_TOKEN = "<UDIM>"


@dataclass(frozen=True)
class UdimGrid:
    """A grid of ``columns`` x ``rows`` UDIM tiles, each ``tile`` = ``(height, width)`` px."""

    columns: int
    rows: int
    tile: tuple[int, int]

    @property
    def shape(self) -> tuple[int, int]:
        """The whole output's ``(height, width)``."""
        return self.rows * self.tile[0], self.columns * self.tile[1]

    @property
    def numbers(self) -> list[int]:
        """The tiles' numbers, ascending (1001, 1002, ..., 1011, ...)."""
        return [udim_number(c, r) for r in range(self.rows) for c in range(self.columns)]

    def tiles(self, image: np.ndarray) -> dict[int, np.ndarray]:
        """``image`` (the whole output, rows down) cut into its tiles: number -> view."""
        h, w = self.tile
        if tuple(image.shape[:2]) != self.shape:
            raise InvalidInputError(
                f"a {self.columns}x{self.rows} UDIM grid of {w}x{h} tiles takes a "
                f"{self.shape[1]}x{self.shape[0]} image, not {image.shape[1]}x{image.shape[0]}"
            )
        return {
            udim_number(c, self.rows - 1 - r): image[r * h : (r + 1) * h, c * w : (c + 1) * w]
            for r in range(self.rows)
            for c in range(self.columns)
        }

    def to_dict(self) -> dict:
        """The grid as a set's JSON records it."""
        return {
            "columns": self.columns,
            "rows": self.rows,
            "tile_width_px": self.tile[1],
            "tile_height_px": self.tile[0],
            "tiles": self.numbers,
        }


def udim_number(column: int, row: int) -> int:
    """The number of the tile at UV square ``(column, row)``: ``1001 + column + 10 * row``."""
    if not (0 <= column < UDIM_MAX_COLUMNS and 0 <= row < UDIM_MAX_ROWS):
        raise InvalidInputError(f"no UDIM tile at column {column}, row {row}")
    return UDIM_FIRST + column + 10 * row


def parse_udim(value, where: str = "--udim") -> tuple[int, int] | None:
    """``"COLSxROWS"`` (``"4x1"``) or a pair -> ``(columns, rows)``; None -> None. Up to
    :data:`UDIM_MAX_COLUMNS` columns and :data:`UDIM_MAX_ROWS` rows."""
    if value is None:
        return None
    if isinstance(value, str):
        match = re.fullmatch(r"\s*(\d{1,3})\s*[xX]\s*(\d{1,3})\s*", value)
        if match is None:
            raise InvalidInputError(f"{where}: {value!r} is no tile grid COLSxROWS (e.g. 4x1)")
        columns, rows = int(match.group(1)), int(match.group(2))
    elif isinstance(value, (list, tuple)) and len(value) == 2 and all(type(v) is int for v in value):
        columns, rows = value
    else:
        raise InvalidInputError(f"{where}: {value!r} is no tile grid COLSxROWS (e.g. 4x1)")
    if not (1 <= columns <= UDIM_MAX_COLUMNS and 1 <= rows <= UDIM_MAX_ROWS):
        raise InvalidInputError(
            f"{where}: {columns}x{rows} tiles; a UDIM grid has 1-{UDIM_MAX_COLUMNS} columns and 1-{UDIM_MAX_ROWS} rows"
        )
    return columns, rows


def udim_grid(shape: tuple[int, int], layout: tuple[int, int]) -> UdimGrid:
    """The grid of ``layout`` (``(columns, rows)``) tiles that cuts an output of ``shape``
    (``(height, width)``) into equal tiles."""
    columns, rows = layout
    h, w = int(shape[0]), int(shape[1])
    if h % rows or w % columns:
        raise InvalidInputError(f"a {w}x{h} output does not cut into {columns}x{rows} equal UDIM tiles")
    return UdimGrid(columns, rows, (h // rows, w // columns))


def udim_file_name(file_name: str, number: int | str) -> str:
    """A map's file name for one tile: ``NAME_Color.png`` -> ``NAME_Color.1001.png`` (or with
    :data:`UDIM_TOKEN`, the name the whole tiled image goes by)."""
    stem, dot, suffix = file_name.rpartition(".")
    if not dot:
        return f"{file_name}.{number}"
    return f"{stem}.{number}.{suffix}"
