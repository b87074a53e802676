"""The progress of a :func:`~barkgen.pipeline.generate` run: each stage (and each step of the
photo's analysis) fills its measured share of the run's time, so that a progress bar moves at
the pace of the clock, and a fraction of the run names the stage then running."""

from __future__ import annotations

from collections.abc import Mapping

from barkgen._shared.arrays import ProgressCallback

#: each stage's share of a run's time, as measured on the quickstart (1024x1024 tileable set from
#: the 1024x1024 sample, 2026-12-02, this machine: analysis 7.0 s, label map 1.7, texture 1.45,
#: material 1.1)
STAGE_SHARES = {"analysis": 0.62, "label_map": 0.15, "texture": 0.13, "material": 0.10}
#: within the analysis: the photo's label map, the two solvers' analyses, and the wait for the
#: photo's material set, made on a second thread beside the solvers' analyses (2.6, 2.7, 1.7, 0 s)
ANALYSIS_SHARES = {"labels": 0.37, "label_map": 0.38, "texture": 0.24, "material": 0.01}


#: what the progress bar says while each stage (and each step of the analysis) runs
_STAGE_TITLES = {
    "analysis": "analysing the photo",
    "label_map": "growing the label map",
    "texture": "texture-by-numbers",
    "material": "making the material set",
}
_ANALYSIS_TITLES = {
    "labels": "its label map",
    "label_map": "its label shapes",
    "texture": "its texture",
    "material": "its relief",
}


#: how far below a stage's end a reported fraction may fall by rounding to 1000ths
_ROUNDING = 2e-3


def share_spans(shares: Mapping[str, float], material: bool) -> dict[str, tuple[float, float]]:
    """Each name's part ``(start, end)`` of 0 to 1 by its share (``material`` only with it)."""
    names = [name for name in shares if material or name != "material"]
    total = sum(shares[name] for name in names)
    spans, start = {}, 0.0
    for name in names:
        spans[name] = (start / total, (start + shares[name]) / total)
        start += shares[name]
    return spans


def stage_span(stage: str, material: bool) -> tuple[float, float]:
    """The part ``(start, end)`` of a run's progress, 0 to 1, that ``stage`` (``"analysis"``,
    ``"label_map"``, ``"texture"`` or ``"material"``) fills: its share of the run's time, so
    that the progress bar moves at the pace of the clock (the material stage only with
    ``material``)."""
    return share_spans(STAGE_SHARES, material)[stage]


def stage_at(fraction: float, material: bool) -> str:
    """What a :func:`generate` run is doing when its progress is at ``fraction`` (0 to 1, the
    ``done / total`` of its progress callback): the stage's title, and within the analysis the
    step's, e.g. ``"analysing the photo: its label map"``. Each stage reports the moment it
    ends, so at a boundary the next stage is named: the one now running.

    Examples
    --------
    >>> stage_at(0.0, material=True)
    'analysing the photo: its label map'
    >>> stage_at(0.95, material=True)
    'making the material set'
    """
    fraction += _ROUNDING  # progress comes in 1000ths, rounded twice within the analysis
    spans = share_spans(STAGE_SHARES, material)
    stage = next((name for name, (_, end) in spans.items() if fraction < end), list(spans)[-1])
    if stage != "analysis":
        return _STAGE_TITLES[stage]
    start, end = spans["analysis"]
    within = (fraction - start) / (end - start)
    steps = share_spans(ANALYSIS_SHARES, material)
    step = next((name for name, (_, stop) in steps.items() if within < stop), list(steps)[-1])
    return f"{_STAGE_TITLES['analysis']}: {_ANALYSIS_TITLES[step]}"


def stage_progress(progress: ProgressCallback | None, stage: str, material: bool) -> ProgressCallback | None:
    """``progress`` seen from within ``stage``: its ``(done, total)`` mapped into the stage's span
    of the run, in 1000ths (None stays None)."""
    if progress is None:
        return None
    lo, hi = stage_span(stage, material)

    def update(done: int, total: int) -> None:
        progress(round(1000 * (lo + (hi - lo) * done / max(total, 1))), 1000)

    return update
