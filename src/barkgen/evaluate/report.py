"""All the measures of one result at once (:func:`evaluate`), read from the arrays or from the
folder ``barkgen generate`` wrote (:func:`evaluate_folder`), as a frozen record with a table."""

from __future__ import annotations

import json
import math
import os
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from barkgen.errors import ImageReadError, InvalidInputError
from barkgen.evaluate.lines import longest_line, wrap_step_ratio
from barkgen.evaluate.patches import coherence, colour_distance, completeness, sharpness_ratio
from barkgen.evaluate.seams import border_step_ratio, largest_copy, longest_seam

#: the texture and the reference map of a ``barkgen generate`` folder
TEXTURE_FILE = "texture.png"
REFERENCE_FILE = "reference.png"
#: the material maps of a folder's set measured by :func:`evaluate_folder` (the MaterialSet fields)
MATERIAL_MAPS = ("height", "normals", "ao", "roughness")


@dataclass(frozen=True)
class MapEvaluation:
    """The straight lines and border steps of one map aligned with the result.

    Attributes
    ----------
    longest_line : int
        :func:`~barkgen.evaluate.longest_line`, px.
    border_step_ratio : float or None
        :func:`~barkgen.evaluate.border_step_ratio` (None without a reference map).
    """

    longest_line: int
    border_step_ratio: float | None = None


@dataclass(frozen=True)
class Evaluation:
    """What :func:`evaluate` measured of a result against its photo (each field is documented
    with the function that computes it; None where it does not apply).

    Attributes
    ----------
    size : (int, int)
        The result's ``(width, height)``.
    coherence, completeness : float
        CIELAB units, lower is better (:func:`~barkgen.evaluate.coherence`).
    sharpness_ratio : float
        1 = as sharp as the photo.
    colour_distance : float
        CIELAB units, lower is better.
    longest_line : int
        px, the result's own straight lines (:func:`~barkgen.evaluate.longest_line`).
    photo_longest_line : int
        px, the photo's, to compare with.
    wrap_step_ratio : float or None
        When the result tiles: :func:`~barkgen.evaluate.wrap_step_ratio`, 1 = seamless.
    largest_copy, longest_seam, border_step_ratio
        From the reference map, when there is one.
    maps : dict of str to MapEvaluation
        Each material or extra map's lines and border steps.
    """

    size: tuple[int, int]
    coherence: float
    completeness: float
    sharpness_ratio: float
    colour_distance: float
    longest_line: int
    photo_longest_line: int
    wrap_step_ratio: float | None = None
    largest_copy: float | None = None
    longest_seam: int | None = None
    border_step_ratio: float | None = None
    maps: dict[str, MapEvaluation] = field(default_factory=dict)

    def as_dict(self) -> dict:
        """The measures as plain JSON-ready values (``None`` for what does not apply and for
        a ratio that has no value, NaN)."""

        def clean(value):
            if isinstance(value, float) and not math.isfinite(value):
                return None
            if isinstance(value, dict):
                return {k: clean(v) for k, v in value.items()}
            if isinstance(value, (list, tuple)):
                return [clean(v) for v in value]
            return value

        return clean(asdict(self))

    def table(self) -> str:
        """The measures as a text table: one line each, its value and what good looks like."""
        rows = [
            ("size", f"{self.size[0]}x{self.size[1]}", ""),
            ("coherence", _fmt(self.coherence), "Lab, lower is better (0 = every patch is in the photo)"),
            ("completeness", _fmt(self.completeness), "Lab, lower is better (0 = all of the photo is shown)"),
            ("sharpness_ratio", _fmt(self.sharpness_ratio), "1 = as sharp as the photo (< 0.5: blurred)"),
            ("colour_distance", _fmt(self.colour_distance), "Lab, lower is better (< 1: the same colours)"),
            ("longest_line", f"{self.longest_line} px", f"the photo's own: {self.photo_longest_line} px"),
        ]
        if self.wrap_step_ratio is not None:
            rows.append(("wrap_step_ratio", _fmt(self.wrap_step_ratio), "1 = the tiles meet without a seam"))
        if self.largest_copy is not None:
            rows += [
                ("largest_copy", _fmt(self.largest_copy), "share of the result pasted in one piece (1 = a plain copy)"),
                ("longest_seam", f"{self.longest_seam} px", "longest straight border between pieces"),
                ("border_step_ratio", _fmt(self.border_step_ratio), "1 = the borders between pieces are invisible"),
            ]
        for name, m in self.maps.items():
            ratio = "" if m.border_step_ratio is None else f", border steps {_fmt(m.border_step_ratio)}"
            rows.append((f"map {name}", f"{m.longest_line} px", f"longest straight line{ratio}"))
        width = max(len(r[0]) for r in rows)
        value_width = max(len(r[1]) for r in rows)
        return "\n".join(f"{n:<{width}}  {v:>{value_width}}  {note}".rstrip() for n, v, note in rows)


def _fmt(value: float | None) -> str:
    if value is None or not math.isfinite(value):
        return "-"
    return f"{value:.3f}"


def _as_map(array: np.ndarray) -> np.ndarray:
    arr = np.asarray(array)
    if arr.dtype == np.bool_:
        arr = arr.astype(np.uint8)
    return arr


def evaluate(
    result: np.ndarray,
    photo: np.ndarray,
    *,
    references: np.ndarray | None = None,
    maps: dict[str, np.ndarray] | None = None,
    tile: bool = False,
    photo_wraps: bool | tuple[bool, bool] = False,
    patch: int = 7,
) -> Evaluation:
    """Every measure of :mod:`barkgen.evaluate` that applies to a result.

    Parameters
    ----------
    result, photo : ndarray
        The synthesised texture and the photo it was made from (sRGB, uint8, uint16 or float).
    references : ndarray of int, shape (H, W, 2), optional
        The result's reference map (``GenerateResult.references``): adds the largest copied
        piece, the longest straight seam and the step ratio across piece borders.
    maps : dict of str to ndarray, optional
        Maps aligned with the result (height, normals, AO, extras): each one's longest line
        and, with ``references``, its step ratio across piece borders.
    tile : bool, default False
        The result tiles (its edges meet).
    photo_wraps : bool or (bool, bool), default False
        The photo tiles itself (along its rows, its columns): references continue across its
        edges. ``report.json``'s and ``GenerateResult.report``'s ``exemplar_wrap`` say it.
    patch : int, default 7
        The patch side of coherence and completeness, px.

    Returns
    -------
    Evaluation

    Raises
    ------
    InvalidInputError
        Images or maps of the wrong shape or size.
    """
    res = np.asarray(result)
    h, w = res.shape[:2]
    for name, arr in [("references", references), *((f"map {k}", v) for k, v in (maps or {}).items())]:
        if arr is not None and np.shape(arr)[:2] != (h, w):
            raise InvalidInputError(f"{name}: {np.shape(arr)[1]}x{np.shape(arr)[0]}, the result is {w}x{h}")
    rows_wrap, cols_wrap = photo_wraps if isinstance(photo_wraps, (tuple, list)) else (photo_wraps, photo_wraps)
    photo_h, photo_w = np.shape(photo)[:2]
    periods = (int(photo_h) if rows_wrap else 0, int(photo_w) if cols_wrap else 0)
    exemplar_wrap = periods if any(periods) else None
    piecewise: dict[str, float | int | None] = dict(largest_copy=None, longest_seam=None, border_step_ratio=None)
    if references is not None:
        piecewise = dict(
            largest_copy=largest_copy(references, tile=tile, exemplar_wrap=exemplar_wrap),
            longest_seam=longest_seam(references, tile=tile, exemplar_wrap=exemplar_wrap),
            border_step_ratio=border_step_ratio(res, references, tile=tile, exemplar_wrap=exemplar_wrap),
        )
    map_figures = {
        name: MapEvaluation(
            longest_line(_as_map(arr), tile=tile),
            None
            if references is None
            else border_step_ratio(_as_map(arr), references, tile=tile, exemplar_wrap=exemplar_wrap),
        )
        for name, arr in sorted((maps or {}).items())
    }
    return Evaluation(
        size=(int(w), int(h)),
        coherence=coherence(res, photo, patch=patch, wrap=tile),
        completeness=completeness(res, photo, patch=patch, wrap=tile),
        sharpness_ratio=sharpness_ratio(res, photo),
        colour_distance=colour_distance(res, photo),
        longest_line=longest_line(res, tile=tile),
        photo_longest_line=longest_line(photo),
        wrap_step_ratio=wrap_step_ratio(res) if tile else None,
        largest_copy=piecewise["largest_copy"],
        longest_seam=None if piecewise["longest_seam"] is None else int(piecewise["longest_seam"]),
        border_step_ratio=piecewise["border_step_ratio"],
        maps=map_figures,
    )


def _folder_report(folder: Path) -> dict:
    try:
        return json.loads((folder / "report.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}


def read_folder(folder: str | os.PathLike) -> dict:
    """What :func:`evaluate_folder` reads of a ``barkgen generate`` folder: ``texture``,
    ``references`` (or None), ``photo_wraps`` (rows, columns), ``tile`` and ``maps`` (the material
    set's height, normals, AO and roughness, and the run's extra maps, by name).

    Raises
    ------
    ImageReadError
        Not a folder, or no ``texture.png`` in it.
    """
    from barkgen.io import find_material, read_image, read_material, read_reference

    folder = Path(folder)
    if not folder.is_dir():
        raise ImageReadError(f"{folder}: not a folder (expected what barkgen generate wrote)")
    if not (folder / TEXTURE_FILE).is_file():
        raise ImageReadError(f"{folder}: no {TEXTURE_FILE} (expected what barkgen generate wrote)")
    report = _folder_report(folder)
    found: dict = {"texture": read_image(folder / TEXTURE_FILE), "references": None}
    found["tile"] = bool(report.get("tile", False))
    wraps = report.get("exemplar_wrap")
    found["photo_wraps"] = (bool(wraps[0]), bool(wraps[1])) if isinstance(wraps, list) and len(wraps) == 2 else False
    if (folder / REFERENCE_FILE).is_file():
        found["references"], _ = read_reference(folder / REFERENCE_FILE)
    maps: dict[str, np.ndarray] = {}
    for extra in report.get("extras") or []:
        if (folder / f"{extra}.png").is_file():
            maps[str(extra)] = read_image(folder / f"{extra}.png")
    if report.get("material"):
        try:
            find_material(folder)
        except ImageReadError:
            pass
        else:
            material, _ = read_material(folder)
            for name in MATERIAL_MAPS:
                value = getattr(material, name, None)
                if value is not None:
                    maps[name] = np.asarray(value)
    found["maps"] = maps
    return found


def evaluate_folder(folder: str | os.PathLike, photo: np.ndarray | str | os.PathLike) -> Evaluation:
    """:func:`evaluate` of what ``barkgen generate`` wrote into ``folder``: its
    ``texture.png``, its ``reference.png`` (the photo's wrap and the output's tiling from
    ``report.json``) and its material and extra maps, against ``photo`` (an array or a path).

    Raises
    ------
    ImageReadError
        No such folder, no texture in it, an unreadable photo.
    InvalidInputError
        Maps of another size than the texture.
    """
    from barkgen.io import read_image

    found = read_folder(folder)
    image = read_image(photo) if isinstance(photo, (str, os.PathLike)) else np.asarray(photo)
    return evaluate(
        found["texture"],
        image,
        references=found["references"],
        maps=found["maps"],
        tile=found["tile"],
        photo_wraps=found["photo_wraps"],
    )
