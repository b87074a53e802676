#!/usr/bin/env python3
"""Visible lines and seams in every map barkgen writes, from whole CLI commands (issue 55).

    .venv/bin/python benchmarks/bench_seams.py [--quick] [--cases sample,crops,extra,untiled,synth]
        [--json OUT.json] [--cache DIR] [--fresh]

Each run is a whole ``python -m barkgen ...`` command, as a user would type it, writing into a
temporary folder; the files it wrote are then measured with :mod:`barkgen.evaluate`:

- :func:`~barkgen.evaluate.longest_line` (pixels alone): the longest straight line (px) of every
  map, tiled for tiled outputs; beside it the same figure for the input photo (tiled when the
  photo wraps on both axes), since bark has its own straight furrows;
- the reference map: the longest straight seam (:func:`~barkgen.evaluate.longest_seam`), and
  every map's step ratio (:func:`~barkgen.evaluate.border_step_ratio`: mean step across piece
  borders over mean step inside pieces; a photo has 1.0), the exemplar wrapping along the axes
  it wraps along (``report.json``'s ``exemplar_wrap`` for generate,
  ``barkgen.synth.exemplar_wraps`` of the exemplar for synth), and the share of the border
  pairs that stack two pieces of one photo column or row
  (:func:`~barkgen.evaluate.stacked_pieces`: the photo's straight edge there runs on).

Maps of ``generate --material``: texture, bark_1K_Color (the albedo), bark_1K_Displacement (16-bit),
bark_1K_NormalGL, bark_1K_AmbientOcclusion, bark_1K_Roughness; bark_1K_NormalDX only when it is not
NormalGL with its green flipped (then its figures are NormalGL's). Files with identical bytes
are measured once. Cases:

1. ``sample``: ``generate --tile --material`` 1024x1024 from the bundled sample, seeds 0-3;
2. ``crops``: the same, seed 0, from 512x512 centre crops (``read_centre_crop``, written as PNG
   into the cache folder) of the ten shared photos ``data/bark/*_01.*``;
3. ``extra``: ``synth --tile --extra height=H.png`` 1024x1024 from the sample, seed 0, where H.png
   is the sample's Displacement from ``material --exemplar-wraps no`` (a height whose own edges
   do not meet: the case that wrote a 503 px line), then from plain ``material`` (auto); seconds
   are the synth command's; "own" is the longest line of H.png itself (tiled as the photo), and below
   the table, on each map of the photo's own material set;
4. ``untiled``: ``generate --material`` (no --tile) 2048x2048 from the sample, seed 0;
5. ``synth``: ``synth --tile --save-reference`` 1024x1024 (colour only) from the sample, seeds
   0-3, and from the ten 512x512 crops, seed 0.

``--quick`` (about 3 minutes): sample seed 0, four crops, the first row of extra, synth from the
sample seed 0; no untiled.

One table per case; map cells are "longest line px / step ratio". After each table, worst and
median over its rows of (a) the longest line over all maps of a row, (b) the longest seam,
(c) the colour step ratio (texture and bark_Color), (d) the worst step ratio of the other maps,
and of the photo's own longest line. At the end, the acceptance of issue 55 over all cases:
longest line <= 96 px, longest seam <= 48 px, colour step ratio <= 1.25, map step ratios <= 1.5.

Every measured row is kept in ``--cache`` (default ``benchmarks/.cache/seams``), keyed by its
commands, its input files, the tools' source and the state of ``src/`` (HEAD, ``git diff`` and
untracked files), so an interrupted run resumes where it stopped; ``--fresh`` ignores the cache.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("BARKGEN_SHARED", REPO.parent / "shared"))
sys.path.insert(0, str(REPO / "src"))

import barkgen.evaluate  # noqa: E402, RUF100
from barkgen.data import sample_exemplar_path  # noqa: E402, RUF100
from barkgen.evaluate import (  # noqa: E402, RUF100
    border_step_ratio,
    longest_line,
    longest_seam,
    piece_borders,
    stacked_pieces,
)
from barkgen.io import read_centre_crop, read_image, read_reference, write_png  # noqa: E402, RUF100
from barkgen.synth import exemplar_wraps  # noqa: E402, RUF100

BARKGEN = [sys.executable, "-m", "barkgen"]
PHOTOS = sorted((SHARED / "data" / "bark").glob("*_01.*"))
QUICK_PHOTOS = ("birch_smooth_lenticels_01", "oak_furrowed_moss_01", "pine_plated_01", "willow_furrowed_01")
CASES = ("sample", "crops", "extra", "untiled", "synth")
CROP = 512
MEASURE_VERSION = 3  # bump when what a row holds changes (3: barkgen.evaluate's measures)
TARGETS = {"line": 96, "seam": 48, "colour": 1.25, "maps": 1.5}
# generate --material: short label -> file in the output folder (NormalDX is checked apart)
GENERATE_MAPS = {
    "tex": "texture.png",
    "color": "SET_Color.png",
    "disp": "SET_Displacement.png",
    "nGL": "SET_NormalGL.png",
    "ao": "SET_AmbientOcclusion.png",
    "rough": "SET_Roughness.png",
}
COLOUR_MAPS = ("tex", "color")


@dataclass
class Run:
    """One row: barkgen commands (``{tmp}`` stands for the temporary folder), the last measured."""

    case: str
    name: str
    kind: str  # "generate" or "synth"
    cmds: list[list[str]]
    tile: bool
    photo: Path  # the exemplar (the bundled sample when the command names none)
    inputs: list[Path] = field(default_factory=list)  # files the commands read besides src/
    extra_own: str | None = None  # {tmp}-relative map whose own lines are shown ("own")


# ---------------------------------------------------------------------------------- cache keys


def _sha(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def file_sha(path: Path) -> str:
    return _sha(Path(path).read_bytes())


def source_state() -> str:
    """HEAD plus a hash of ``git diff HEAD -- src`` and of the untracked files under src/."""

    def git(*args: str) -> bytes:
        return subprocess.run(["git", "-C", str(REPO), *args], capture_output=True, check=True).stdout

    h = hashlib.sha256(git("diff", "HEAD", "--binary", "--", "src"))
    for name in sorted(git("ls-files", "--others", "--exclude-standard", "-z", "--", "src").split(b"\0")):
        if name:
            h.update(name + b"\0")
            p = REPO / name.decode()
            h.update(p.read_bytes() if p.is_file() else b"")
    return git("rev-parse", "HEAD").decode().strip() + "+" + h.hexdigest()[:16]


def tools_state() -> str:
    tools = sorted(Path(barkgen.evaluate.__file__).parent.glob("*.py"))
    return _sha(b"".join(p.read_bytes() for p in tools) + str(MEASURE_VERSION).encode())[:16]


def run_key(run: Run, src: str) -> str:
    return _sha(
        json.dumps(
            {
                "cmds": run.cmds,
                "tile": run.tile,
                "kind": run.kind,
                "inputs": {str(p): file_sha(p) for p in run.inputs},
                "photo": file_sha(run.photo),
                "src": src,
                "tools": tools_state(),
            }
        ).encode()
    )[:24]


# ---------------------------------------------------------------------------------- measuring

_LINES: dict = {}


def measure_lines(path: Path, tile: bool) -> dict:
    """The longest straight line of one file, once per (content, tile)."""
    key = (file_sha(path), tile)
    if key not in _LINES:
        _LINES[key] = {"lines": longest_line(read_image(path), tile=tile), "lines_where": None}
    return dict(_LINES[key])


def photo_lines(photo: Path) -> dict:
    """The input photo's own longest line (tiled when it wraps on both axes)."""
    tile = all(exemplar_wraps(read_image(photo)))
    return {"path": str(photo), "tile": tile, **measure_lines(photo, tile)}


def normal_dx_is_flip(gl: Path, dx: Path) -> bool:
    a, b = (cv2.imread(str(p), cv2.IMREAD_UNCHANGED) for p in (gl, dx))
    if a is None or b is None or a.shape != b.shape or a.dtype != b.dtype or a.ndim != 3:
        return False
    top = np.iinfo(a.dtype).max
    flip = b.copy()
    flip[..., 1] = top - b[..., 1]  # BGR: green is channel 1
    return bool(np.array_equal(a, flip))


def expand(cmd: list[str], tmp: Path) -> list[str]:
    return [s.replace("{tmp}", str(tmp)) for s in cmd]


def execute(run: Run) -> dict:
    """Run the commands in a temporary folder and measure what the last one wrote."""
    with tempfile.TemporaryDirectory(prefix="bench_seams_") as d:
        tmp = Path(d)
        seconds = []
        for cmd in run.cmds:
            t0 = time.perf_counter()
            proc = subprocess.run(BARKGEN + expand(cmd, tmp), capture_output=True, text=True, check=False, cwd=tmp)
            seconds.append(time.perf_counter() - t0)
            if proc.returncode:
                tail = "\n".join((proc.stderr or proc.stdout).strip().splitlines()[-6:])
                raise RuntimeError(f"barkgen {' '.join(cmd)} exited {proc.returncode}:\n{tail}")
        if run.kind == "generate":
            out = tmp / "out"
            ref = out / "reference.png"
            set_name = next(out.glob("*_Color.png")).name[: -len("_Color.png")]  # (bark_1K: its size tag)
            files = {k: out / f.replace("SET", set_name) for k, f in GENERATE_MAPS.items()}
            dx = out / f"{set_name}_NormalDX.png"
            dx_flip = normal_dx_is_flip(files["nGL"], dx)
            if not dx_flip:
                files["nDX"] = dx
            wrap = [bool(v) for v in json.loads((out / "report.json").read_text())["exemplar_wrap"]]
        else:
            ref = tmp / "ref.png"
            files = {"tex": tmp / "out.png"}
            if (tmp / "out_height.png").exists():
                files["height"] = tmp / "out_height.png"
            dx_flip = None
            wrap = [bool(v) for v in exemplar_wraps(read_image(run.photo))]
        missing = [str(p) for p in [ref, *files.values()] if not p.exists()]
        if missing:
            raise RuntimeError(f"not written: {', '.join(missing)}")
        # the reference map's seams and each distinct file's step ratio, once
        unique: dict[str, Path] = {}
        for p in files.values():
            unique.setdefault(file_sha(p), p)
        references, exemplar_shape = read_reference(ref)
        shape = exemplar_shape or (int(references[..., 0].max()) + 1, int(references[..., 1].max()) + 1)
        wraps = {"tile": run.tile, "exemplar_wrap": tuple(n if w else 0 for n, w in zip(shape, wrap))}
        steps = {h: border_step_ratio(read_image(p), references, **wraps) for h, p in unique.items()}
        steps = {h: (None if np.isnan(v) else v) for h, v in steps.items()}  # one piece: no border
        across_rows, across_cols = piece_borders(references, **wraps)
        s = {
            "longest": longest_seam(references, **wraps),
            "where": None,
            "seam_share": float((across_rows.mean() + across_cols.mean()) / 2),
            # border pairs that stack two pieces of one photo column or row (the photo's straight
            # edge there runs on across them), of all border pairs
            "stacked": stacked_pieces(references, **wraps),
        }
        maps = {}
        for k, p in files.items():
            maps[k] = {"file": p.name, **measure_lines(p, run.tile), "step": steps[file_sha(p)]}
        row = {
            "case": run.case,
            "name": run.name,
            "cmds": [" ".join(["barkgen", *c]) for c in run.cmds],
            "seconds": round(seconds[-1], 2),
            "seconds_all": [round(t, 2) for t in seconds],
            "tile": run.tile,
            "exemplar_wrap": wrap,
            "seam": s,
            "maps": maps,
            "normal_dx_is_gl_flipped": dx_flip,
            "photo": photo_lines(run.photo),
        }
        if run.extra_own:
            own = tmp / run.extra_own
            row["own"] = {"file": own.name, "tile": row["photo"]["tile"], **measure_lines(own, row["photo"]["tile"])}
            # the photo's whole material set beside it: lines a map has on the photo itself
            row["own_maps"] = {
                k: {"file": f, **measure_lines(own.parent / f, row["own"]["tile"])}
                for k, f in GENERATE_MAPS.items()
                if (own.parent / f).exists()
            }
        return row


def summarise(row: dict) -> dict:
    """(a) longest line over all maps, (b) seam, (c) colour step, (d) other maps' worst step."""
    maps = row["maps"]
    worst_line = max(maps, key=lambda k: maps[k]["lines"])
    colour = [(maps[k]["step"], k) for k in COLOUR_MAPS if k in maps and maps[k]["step"] is not None]
    other = [(m["step"], k) for k, m in maps.items() if k not in COLOUR_MAPS and m["step"] is not None]
    return {
        "line": (maps[worst_line]["lines"], worst_line),
        "seam": (row["seam"]["longest"], None),
        "colour": max(colour) if colour else (None, None),
        "maps": max(other) if other else (None, None),
        "photo": (row["photo"]["lines"], None),
    }


# ---------------------------------------------------------------------------------- cases


def crop_path(photo: Path, cache: Path) -> Path:
    out = cache / "crops" / f"{photo.stem}_{CROP}.png"
    if not out.exists():
        out.parent.mkdir(parents=True, exist_ok=True)
        write_png(out, read_centre_crop(photo, CROP))
    return out


def short(photo: Path) -> str:
    return photo.stem.removesuffix(f"_{CROP}").removesuffix("_01")


def generate_cmd(photo: Path | None, size: int, tile: bool, seed: int) -> list[str]:
    return [
        "generate",
        *([str(photo)] if photo else []),
        "-o",
        "{tmp}/out",
        "--size",
        f"{size}x{size}",
        *(["--tile"] if tile else []),
        "--seed",
        str(seed),
        "--material",
        "--name",
        "bark",
        "-q",
    ]


def synth_cmd(photo: Path | None, seed: int, extra: str | None = None) -> list[str]:
    return [
        "synth",
        *([str(photo)] if photo else []),
        "-o",
        "{tmp}/out.png",
        "--size",
        "1024x1024",
        "--tile",
        "--seed",
        str(seed),
        "--save-reference",
        "{tmp}/ref.png",
        *(["--extra", f"height={extra}"] if extra else []),
        "-q",
    ]


def plan(case: str, quick: bool, cache: Path) -> list[Run]:
    sample = sample_exemplar_path()
    seeds = [0] if quick else [0, 1, 2, 3]
    photos = [p for p in PHOTOS if p.stem in QUICK_PHOTOS] if quick else PHOTOS
    if case == "sample":
        return [
            Run(case, f"sample seed {s}", "generate", [generate_cmd(None, 1024, True, s)], True, sample) for s in seeds
        ]
    if case == "crops":
        runs = []
        for p in photos:
            c = crop_path(p, cache)
            runs.append(Run(case, f"{short(c)} seed 0", "generate", [generate_cmd(c, 1024, True, 0)], True, c, [c]))
        return runs
    if case == "extra":
        runs = []
        for mode in ["no"] if quick else ["no", "auto"]:
            wraps = ["--exemplar-wraps", mode] if mode != "auto" else []
            mat = ["material", "-o", "{tmp}/mat", "--name", "bark", *wraps, "-q"]
            h = "{tmp}/mat/bark_1K_Displacement.png"
            runs.append(
                Run(
                    case,
                    f"height wraps {mode}",
                    "synth",
                    [mat, synth_cmd(None, 0, h)],
                    True,
                    sample,
                    extra_own="mat/bark_1K_Displacement.png",
                )
            )
        return runs
    if case == "untiled":
        return [Run(case, "sample 2048 seed 0", "generate", [generate_cmd(None, 2048, False, 0)], False, sample)]
    if case == "synth":
        runs = [Run(case, f"sample seed {s}", "synth", [synth_cmd(None, s)], True, sample) for s in seeds]
        if not quick:
            for p in photos:
                c = crop_path(p, cache)
                runs.append(Run(case, f"{short(c)} seed 0", "synth", [synth_cmd(c, 0)], True, c, [c]))
        return runs
    raise ValueError(case)


TITLES = {
    "sample": "sample: generate --tile --material 1024x1024 from the bundled sample",
    "crops": f"crops: generate --tile --material 1024x1024 from {CROP}x{CROP} centre crops, seed 0",
    "extra": "extra: synth --tile --extra height=H.png 1024x1024 from the sample, seed 0 (H = material's Displacement)",
    "untiled": "untiled: generate --material (no --tile) 2048x2048 from the sample",
    "synth": "synth: synth --tile --save-reference 1024x1024, colour only",
}


# ---------------------------------------------------------------------------------- output


def where(w) -> str:
    """(axis, boundary/index, start) -> 'col 505 @36'."""
    return f"{w[0]} {w[1]} @{w[2]}" if w else "-"


def cell(m: dict) -> str:
    return f"{m['lines']}/{'-' if m['step'] is None else format(m['step'], '.2f')}"


def table(case: str, rows: list[dict]) -> None:
    print(f"\n{TITLES[case]}")
    labels = []
    for r in rows:
        labels += [k for k in r["maps"] if k not in labels]
    own = any("own" in r for r in rows)
    header = ("case", "s", "seam", "stack", "photo", *(["own"] if own else []), *labels)
    body = []
    for r in rows:
        body.append(
            (
                r["name"],
                f"{r['seconds']:.1f}",
                str(r["seam"]["longest"]),
                stacked_share(r),
                str(r["photo"]["lines"]),
                *([str(r["own"]["lines"])] if own else []),
                *(cell(r["maps"][k]) if k in r["maps"] else "" for k in labels),
            )
        )
    widths = [max(len(x[i]) for x in body + [header]) for i in range(len(header))]
    print("  ".join(h.ljust(w) if i == 0 else h.rjust(w) for i, (h, w) in enumerate(zip(header, widths))))
    for x in body:
        print("  ".join(v.ljust(w) if i == 0 else v.rjust(w) for i, (v, w) in enumerate(zip(x, widths))))
    print(
        "(seam, photo, own: longest px; stack: share of the border pairs stacking two pieces of one"
        " photo column or row; map cells: longest line px / step ratio across seams)"
    )
    for r in rows:
        if r.get("own_maps"):
            print(
                f"{r['name']}: the photo's own material set, longest line px: "
                + "  ".join(f"{k} {m['lines']}" for k, m in r["own_maps"].items())
            )
    summary(rows)


def stacked_share(row: dict) -> str:
    """The row's share of stacked border pairs (:func:`barkgen.evaluate.stacked_pieces`), in %."""
    stacked = row["seam"].get("stacked")  # rows cached before the count was kept have none
    return f"{100.0 * stacked[0] / max(stacked[1], 1):.1f}%" if stacked else "-"


def stats(rows: list[dict], metric: str):
    """(worst value, its row, its map, median) of one metric over rows, or None."""
    vals = [(summarise(r)[metric], r) for r in rows]
    vals = [((v, k), r) for (v, k), r in vals if v is not None]
    if not vals:
        return None
    (v, k), r = max(vals, key=lambda t: t[0][0])
    return v, r, k, statistics.median(x[0][0] for x in vals)


def fmt(metric: str, v: float) -> str:
    return f"{v:.2f}" if metric in ("colour", "maps") else f"{v:g}"


def summary(rows: list[dict]) -> None:
    names = {
        "line": "(a) longest line, all maps",
        "seam": "(b) longest seam",
        "colour": "(c) colour step ratio",
        "maps": "(d) worst other map step ratio",
        "photo": "    beside the photo's own line",
    }
    for metric, label in names.items():
        s = stats(rows, metric)
        if s is None:
            print(f"{label:<32} -")
            continue
        v, r, k, med = s
        at = (
            where(r["maps"][k]["lines_where"])
            if metric == "line"
            else (where(r["seam"]["where"]) if metric == "seam" else "")
        )
        print(
            f"{label:<32} worst {fmt(metric, v)}  median {fmt(metric, med)}"
            f"   ({r['name']}{' ' + k if k else ''}{' ' + at if at else ''})"
        )


def acceptance(rows: list[dict], failed: list[str]) -> bool:
    print("\nacceptance (issue 55), worst over all cases:")
    names = {
        "line": ("longest line", "px"),
        "seam": ("longest seam", "px"),
        "colour": ("colour step ratio", ""),
        "maps": ("map step ratios", ""),
    }
    ok = not failed
    for metric, (label, unit) in names.items():
        s = stats(rows, metric)
        target = TARGETS[metric]
        if s is None:
            print(f"  {label:<18} {'-':>6}      target <= {target:<5}  n/a")
            continue
        v, r, k, _ = s
        good = v <= target
        ok &= good
        print(
            f"  {label:<18} {fmt(metric, v):>6} {unit:<3}  target <= {target:<5}  "
            f"{'PASS' if good else 'FAIL'}   ({r['case']}: {r['name']}{' ' + k if k else ''})"
        )
    s = stats(rows, "photo")
    if s:
        print(f"  (the photos' own longest line: worst {s[0]} px, {s[1]['case']}: {s[1]['name']})")
    if failed:
        print(f"  {len(failed)} run(s) failed, not measured: {', '.join(failed)}  FAIL")
    print(f"  overall: {'PASS' if ok else 'FAIL'}")
    return ok


# ---------------------------------------------------------------------------------- main


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default=",".join(CASES), help=f"comma list of {', '.join(CASES)} (default: all)")
    ap.add_argument(
        "--quick",
        action="store_true",
        help="about 3 minutes: sample seed 0, four crops, extra's first row, synth from the sample seed 0; no untiled",
    )
    ap.add_argument("--json", metavar="OUT.json", help="write every measured row")
    ap.add_argument(
        "--cache",
        type=Path,
        default=REPO / "benchmarks" / ".cache" / "seams",
        metavar="DIR",
        help="measured rows and crops (default: %(default)s)",
    )
    ap.add_argument("--fresh", action="store_true", help="ignore cached rows (and replace them)")
    a = ap.parse_args()
    sys.stdout.reconfigure(line_buffering=True)  # tables and stderr progress in order
    cases = [c for c in a.cases.split(",") if c]
    unknown = sorted(set(cases) - set(CASES))
    if unknown:
        ap.error(f"unknown case(s) {', '.join(unknown)}; choose from {', '.join(CASES)}")
    if a.quick:
        cases = [c for c in cases if c != "untiled"]
    cases = [c for c in CASES if c in cases]
    rows_dir = a.cache / "rows"
    rows_dir.mkdir(parents=True, exist_ok=True)
    sample = sample_exemplar_path()
    print(
        f"barkgen {source_state()}; sample {sample.name}: exemplar_wraps (rows, cols) = "
        f"{exemplar_wraps(read_image(sample))}; {len(PHOTOS)} shared photos"
    )
    t_start = time.perf_counter()
    all_rows: list[dict] = []
    failed: list[str] = []
    for case in cases:
        runs = plan(case, a.quick, a.cache)
        rows = []
        for i, run in enumerate(runs, 1):
            state = source_state()  # per row: the other engineer may edit src/ meanwhile
            key = run_key(run, state)
            path = rows_dir / f"{key}.json"
            tag = f"[{case} {i}/{len(runs)}] {run.name}"
            if path.exists() and not a.fresh:
                row = json.loads(path.read_text())
                print(f"{tag}: cached ({row['seconds']:.1f} s when run)", file=sys.stderr)
            else:
                try:
                    row = execute(run)
                except (RuntimeError, OSError, subprocess.SubprocessError) as e:
                    print(f"{tag}: FAILED\n{e}", file=sys.stderr)
                    failed.append(f"{case}: {run.name}")
                    continue
                row["key"], row["src"] = key, state
                tmp_path = path.with_suffix(".tmp")
                tmp_path.write_text(json.dumps(row, indent=1))
                tmp_path.replace(path)
                print(f"{tag}: {row['seconds']:.1f} s", file=sys.stderr)
            rows.append(row)
        if rows:
            table(case, rows)
            sys.stdout.flush()
        all_rows += rows
    if all_rows:
        acceptance(all_rows, failed)
    states = {r.get("src") for r in all_rows}
    if len(states) > 1:
        print(
            f"note: the rows were measured on {len(states)} states of src/ (it changed between runs; 'src' in --json)"
        )
    print(f"\n{len(all_rows)} rows, {time.perf_counter() - t_start:.0f} s")
    if a.json:
        Path(a.json).write_text(json.dumps(all_rows, indent=1))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
