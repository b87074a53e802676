#!/usr/bin/env python3
"""Same bytes before and after a change that should not move any output (a layout change, a
rename, a refactor): every command of the CLI on the bundled sample (and a crack image of
``../shared/data`` when there is one), small sizes, fixed seeds; the SHA-256 of every file
written (``report.json`` without its timings, the JSON of a run with its photo's file name
only: the folder is a new temporary one each run).

    .venv/bin/python benchmarks/same_bytes.py --out after.json
    .venv/bin/python benchmarks/same_bytes.py --out before.json --src /tmp/base/src
    .venv/bin/python benchmarks/same_bytes.py --compare before.json after.json

``--src`` runs another checkout's ``src`` (``git worktree add /tmp/base COMMIT``) with this
interpreter. ``--cases branches,bilayer`` runs only the cases whose names start so (and the cases
they read from). ``--compare`` prints the files whose bytes differ and exits 1 if any do; it
compares the cases both files hold.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("BARKGEN_SHARED", REPO.parent / "shared"))

#: (name, arguments); {sample}, {crop}, {cracks} and {out} are filled in; each runs in its own
#: folder {out}
CASES: list[tuple[str, list[str]]] = [
    (
        "synth_tiled",
        [
            "synth",
            "{crop}",
            "-o",
            "{out}/t.png",
            "--size",
            "512x384",
            "--tile",
            "--seed",
            "3",
            "--save-reference",
            "{out}/ref.png",
            "--extra",
            "grey={crop_grey}",
        ],
    ),
    (
        "synth_untiled",
        ["synth", "{crop}", "-o", "{out}/t.png", "--size", "384x512", "--seed", "1", "--exemplar-wraps", "no"],
    ),
    ("apply_reference", ["apply-reference", "{prev}/synth_tiled/ref.png", "{crop_grey}", "-o", "{out}/a.png"]),
    ("labels", ["labels", "{crop}", "-o", "{out}/labels.png", "--k", "3"]),
    (
        "shapes",
        [
            "shapes",
            "{prev}/labels/labels.png",
            "-o",
            "{out}/shapes.png",
            "--size",
            "320x320",
            "--strategy",
            "joint",
            "--photo",
            "{crop}",
            "--seed",
            "2",
        ],
    ),
    (
        "shapes_layered",
        [
            "shapes",
            "{prev}/labels/labels.png",
            "-o",
            "{out}/shapes.png",
            "--size",
            "256x256",
            "--strategy",
            "layered",
            "--seed",
            "2",
        ],
    ),
    (
        "tbn",
        [
            "tbn",
            "{crop}",
            "--labels",
            "{prev}/labels/labels.png",
            "--target",
            "{prev}/shapes/shapes.png",
            "-o",
            "{out}/tbn.png",
            "--seed",
            "4",
        ],
    ),
    (
        "quickstart",
        ["generate", "-o", "{out}", "--size", "1024x1024", "--tile", "--seed", "0", "--material", "--name", "bark"],
    ),
    (
        "generate_material",
        [
            "generate",
            "{crop}",
            "-o",
            "{out}",
            "--size",
            "384x384",
            "--tile",
            "--seed",
            "0",
            "--material",
            "--name",
            "bark",
            "--k",
            "3",
        ],
    ),
    ("material", ["material", "{crop}", "-o", "{out}"]),
    ("preview", ["preview", "{prev}/generate_material", "-o", "{out}/trunk.png"]),
    ("export_glb", ["export-glb", "{prev}/generate_material", "-o", "{out}/trunk.glb"]),
    ("bilayer_analyze", ["bilayer", "analyze", "{crop}", "-o", "{out}/m.npz", "--k", "2", "--tloc", "8"]),
    (
        "bilayer_synth",
        [
            "bilayer",
            "synth",
            "{prev}/bilayer_analyze/m.npz",
            "-o",
            "{out}/b.png",
            "--size",
            "384x256",
            "--offset",
            "1000,-300",
            "--seed",
            "5",
        ],
    ),
    ("branches_extract", ["branches", "extract", "{cracks}", "-o", "{out}/src.json"]),
    (
        "branches_grow",
        [
            "branches",
            "grow",
            "{prev}/branches_extract/src.json",
            "-o",
            "{out}/grown.json",
            "--size",
            "256x256",
            "--seed",
            "1",
        ],
    ),
    (
        "branches_render",
        [
            "branches",
            "render",
            "{cracks}",
            "{prev}/branches_extract/src.json",
            "{prev}/branches_grow/grown.json",
            "-o",
            "{out}/r.png",
            "--seed",
            "1",
        ],
    ),
]

#: the commands without a progress bar (no --quiet)
NO_QUIET = {"apply_reference", "preview", "export_glb", "bilayer_synth"}


def make_inputs(folder: Path, env: dict) -> dict[str, str]:
    """A 256 px crop of the bundled sample (and its grey as an extra map), and a crack image."""
    code = (
        "import sys, numpy as np\n"
        "from barkgen.data import sample_exemplar_path\n"
        "from barkgen.io import read_image, write_png\n"
        "img = read_image(sample_exemplar_path())\n"
        "crop = np.ascontiguousarray(img[300:556, 400:656])\n"
        "write_png(sys.argv[1], crop)\n"
        "write_png(sys.argv[2], crop.mean(axis=2).astype(np.uint8))\n"
    )
    crop, grey = folder / "crop.png", folder / "crop_grey.png"
    subprocess.run([sys.executable, "-c", code, str(crop), str(grey)], check=True, env=env)
    cracks = SHARED / "data" / "branching" / "dried_mud_01.jpg"
    return {"crop": str(crop), "crop_grey": str(grey), "cracks": str(cracks) if cracks.exists() else ""}


def digest(path: Path) -> str:
    data = path.read_bytes()
    if path.suffix == ".json" and path.name != "src.json" and path.name != "grown.json":
        report = json.loads(data)
        report.pop("timings_s", None)
        for key in ("photo", "source_photo"):  # paths in this run's temporary folder
            if isinstance(report.get(key), str):
                report[key] = Path(report[key]).name
        # the hashes of the run's other JSON files (they hold the run's paths): each of those
        # files is digested here itself, normalised
        recorded = report.get("file_sha256")
        if isinstance(recorded, dict):
            report["file_sha256"] = {n: h for n, h in recorded.items() if not n.endswith(".json")}
        data = json.dumps(report, sort_keys=True).encode()
    return hashlib.sha256(data).hexdigest()


def selected_cases(prefixes: list[str] | None) -> list[tuple[str, list[str]]]:
    """The cases whose names start with one of ``prefixes`` (all when None), with the cases
    whose folders they read (``{prev}/NAME/``)."""
    if not prefixes:
        return CASES
    wanted = {name for name, _ in CASES if name.startswith(tuple(prefixes))}
    args_of = dict(CASES)
    pending = list(wanted)
    while pending:
        for arg in args_of[pending.pop()]:
            if arg.startswith("{prev}/"):
                need = arg.split("/")[1]
                if need not in wanted:
                    wanted.add(need)
                    pending.append(need)
    return [(name, args) for name, args in CASES if name in wanted]


def run_cases(src: Path | None, prefixes: list[str] | None = None) -> dict[str, str]:
    env = dict(os.environ)
    if src is not None:
        env["PYTHONPATH"] = str(src) + os.pathsep + env.get("PYTHONPATH", "")
    hashes: dict[str, str] = {}
    with tempfile.TemporaryDirectory(prefix="same-bytes-") as tmp:
        root = Path(tmp)
        values = make_inputs(root, env)
        for name, args in selected_cases(prefixes):
            if "{cracks}" in " ".join(args) and not values["cracks"]:
                print(f"{name}: skipped (no crack image in {SHARED})", file=sys.stderr)
                continue
            out = root / name
            out.mkdir()
            argv = [a.format(out=out, prev=root, **values) for a in args]
            quiet = [] if name in NO_QUIET else ["--quiet"]
            result = subprocess.run(
                [sys.executable, "-m", "barkgen", *argv, *quiet], capture_output=True, text=True, env=env
            )
            if result.returncode != 0:
                raise SystemExit(f"{name} failed ({result.returncode}): {result.stderr.strip()[-400:]}")
            for path in sorted(out.rglob("*")):
                if path.is_file():
                    hashes[f"{name}/{path.relative_to(out)}"] = digest(path)
            print(f"{name}: {sum(k.startswith(name + '/') for k in hashes)} files", file=sys.stderr)
    return hashes


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, help="write the hashes here (JSON)")
    parser.add_argument("--src", type=Path, help="run this checkout's src instead of the installed barkgen")
    parser.add_argument("--cases", help="comma-separated case name prefixes (default: all)")
    parser.add_argument("--compare", nargs=2, type=Path, metavar=("BEFORE", "AFTER"))
    args = parser.parse_args()
    if args.compare:
        a, b = (json.loads(p.read_text()) for p in args.compare)
        common = {k.split("/")[0] for k in a} & {k.split("/")[0] for k in b}
        a, b = ({k: v for k, v in d.items() if k.split("/")[0] in common} for d in (a, b))
        differ = sorted(k for k in set(a) | set(b) if a.get(k) != b.get(k))
        print(
            f"| files | same | differ |\n|---|---|---|\n| {len(set(a) | set(b))} | "
            f"{len(set(a) | set(b)) - len(differ)} | {len(differ)} |"
        )
        for k in differ:
            print(f"  differs: {k} ({'missing before' if k not in a else 'missing after' if k not in b else 'bytes'})")
        sys.exit(1 if differ else 0)
    hashes = run_cases(args.src, args.cases.split(",") if args.cases else None)
    text = json.dumps(hashes, indent=1, sort_keys=True)
    if args.out:
        args.out.write_text(text + "\n")
    print(f"{len(hashes)} files hashed", file=sys.stderr)


if __name__ == "__main__":
    main()
