"""Every name barkgen writes for one photo, as an artist's library sorts them (issue 66).

One photo (the bundled sample, or ``--photo``) at 1K and 2K and a relief-edited variant, through
every front end that writes a material set: ``generate`` (its run layout and ``--layout
library``), ``export-glb``, ``batch`` and the web app (its zip, its glb and its Blender zip).
For each it lists the files and checks that every file of the set carries the asset and the
size tag, and that no two runs' files collide. Prints a table; ``--markdown`` writes it for the
docs.

    .venv/bin/python benchmarks/bench_names.py [--photo PHOTO] [--markdown FILE]
"""

from __future__ import annotations

import argparse
import io
import json
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

BARKGEN = [sys.executable, "-m", "barkgen"]
SIZES = {"1K": "1024x1024", "2K": "2048x2048"}
RUN_FILES = {"texture.png", "labels_in.png", "labels_out.png", "reference.png", "preview.png", "report.json"}


def cli(*args: str, cwd: Path | None = None) -> None:
    done = subprocess.run([*BARKGEN, *args], capture_output=True, text=True, cwd=cwd, check=False)
    if done.returncode:
        raise SystemExit(f"barkgen {' '.join(args)}: {done.stderr.strip()}")


def listing(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.is_file())


def cli_rows(photo: Path, tmp: Path) -> list[tuple[str, str, list[str]]]:
    """(front end, case, file names) of the CLI and batch."""
    rows = []
    edits = tmp / "edits.json"
    edits.write_text(json.dumps({"version": 1, "edits": [{"x": 100, "y": 80, "delta": 2.0}], "relief": 1.5}))
    for tag, size in SIZES.items():
        out = tmp / f"run_{tag}"
        cli("generate", str(photo), "-o", str(out), "--size", size, "--tile", "--seed", "7", "--material", "-q")
        rows.append(("generate", tag, listing(out)))
        cli("export-glb", str(out), "--segments", "64", cwd=out)
        rows.append(("export-glb", tag, [n for n in listing(out) if n.endswith(".glb")]))
    lib = tmp / "library"
    for tag, size in SIZES.items():
        args = ["-o", str(lib), "--size", size, "--tile", "--seed", "7", "--material", "--layout", "library", "-q"]
        cli("generate", str(photo), *args)
    cli(
        "generate",
        str(photo),
        *["-o", str(lib), "--size", "1024x1024", "--tile", "--seed", "7", "--material", "--layout", "library"],
        *["--edits", str(edits), "-q"],
    )
    rows.append(("generate --layout library", "1K, 2K, 1K edited, one folder", listing(lib)))
    edited = tmp / "edited"
    cli("generate", str(photo), "-o", str(edited), "--size", "1024x1024", "--tile", "--seed", "7", "--material")
    cli(
        "generate",
        str(photo),
        *["-o", str(edited), "--size", "1024x1024", "--tile", "--seed", "7", "--material", "--edits", str(edits)],
    )
    rows.append(("generate --edits", "1K relief-edited", listing(edited)))
    spec = tmp / "spec.json"
    spec.write_text(
        json.dumps(
            {"tile": True, "material": True, "exemplars": [{"path": str(photo), "seeds": [7, 8], "licence": "MIT"}]}
        )
    )
    cli("batch", str(spec), "-o", str(tmp / "batch"), "-q")
    for folder in sorted(p for p in (tmp / "batch").glob("*/*") if p.is_dir()):
        rows.append(("batch", f"1K seed {folder.name}", listing(folder)))
    return rows


def web_rows(photo: Path, tmp: Path) -> tuple[list[tuple[str, str, list[str]]], str]:
    """(front end, case, file names) of the web app's downloads, and the asset name (the
    library entry's: the photo's file name, or the name it was given or already had)."""
    from fastapi.testclient import TestClient

    from barkgen.io import asset_slug
    from barkgen.library import Library
    from barkgen.web import create_app

    rows = []
    with TestClient(create_app(Library(tmp / "weblib"))) as client:
        exemplar = client.post(
            "/api/exemplars", files={"file": (photo.name, photo.read_bytes())}, data={"licence": "MIT"}
        ).json()
        results = {}
        for tag, size in SIZES.items():
            params = {"exemplar_id": exemplar["id"], "size": size, "tile": True, "material": True, "seed": 7}
            results[tag] = wait(client, client.post("/api/jobs", json=params).json()["id"])
        relief = {"result_id": results["1K"]["result_id"], "edits": [{"x": 100, "y": 80, "delta": 2.0}], "relief": 1.5}
        params = {"exemplar_id": exemplar["id"], "size": "1024x1024", "tile": True, "material": True, "seed": 7}
        results["1K relief-edited"] = wait(
            client, client.post("/api/jobs", json={**params, "relief_edits": relief}).json()["id"]
        )
        for case, job in results.items():
            result = client.get(f"/api/results/{job['result_id']}").json()
            for kind in ("zip", "blender"):
                url = result["download_url"] if kind == "zip" else result["downloads"]["blender"]["url"]
                response = client.get(url)
                name = response.headers["content-disposition"].split('filename="')[1].rstrip('"')
                names = zipfile.ZipFile(io.BytesIO(response.content)).namelist()
                rows.append((f"web {kind}", case, [name, *(f"  {n}" for n in sorted(names))]))
            rows.append(("web glb", case, [result["downloads"]["glb"]["name"]]))
        name = client.get(f"/api/exemplars/{exemplar['id']}").json()["name"]
    return rows, asset_slug(name)


def wait(client, job_id: str, timeout: float = 600) -> dict:
    deadline = time.monotonic() + timeout
    while True:
        job = client.get(f"/api/jobs/{job_id}").json()
        if job["state"] in ("done", "failed", "cancelled"):
            if job["state"] != "done":
                raise SystemExit(f"web job {job_id}: {job}")
            return job
        if time.monotonic() > deadline:
            raise SystemExit(f"web job {job_id} not done in {timeout} s")
        time.sleep(0.2)


def check(rows, assets: tuple[str, ...]) -> list[str]:
    """Problems: a file without the asset or a size tag (a run folder's own record aside); one
    name written by two cases of one front end (the same seed and size through two front ends
    is the same set, and may share its name)."""
    problems, owners = [], {}
    for front, case, names in rows:
        for raw in names:
            name = raw.strip()
            if front in ("generate", "generate --edits", "batch") and name in RUN_FILES | {"illumination.png"}:
                continue  # the run's own record in its folder (--layout library names them too)
            if not name.startswith(assets) or not any(t in name for t in ("_1K", "_2K")):
                problems.append(f"{front} {case}: {name} lacks the asset or the size")
            owners.setdefault((front, name), set()).add(case)
    for (front, name), cases in owners.items():
        if len(cases) > 1:
            problems.append(f"{front}: {name} written by {sorted(cases)}")
    return problems


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--photo", type=Path, help="default: the bundled sample")
    parser.add_argument("--markdown", type=Path, help="also write the table as Markdown here")
    args = parser.parse_args()
    from barkgen.data import sample_exemplar_path
    from barkgen.io import photo_asset_name

    photo = (args.photo or sample_exemplar_path()).resolve()
    with tempfile.TemporaryDirectory(prefix="bench-names-") as folder:
        tmp = Path(folder)
        web, web_asset = web_rows(photo, tmp)
        rows = cli_rows(photo, tmp) + web
    lines = ["| front end | case | files |", "|---|---|---|"]
    for front, case, names in rows:
        lines.append(f"| {front} | {case} | {'<br>'.join(f'`{n.strip()}`' for n in names)} |")
    problems = check(rows, (photo_asset_name(photo), web_asset))
    table = "\n".join(lines)
    print(table)
    print("\n" + ("\n".join(problems) if problems else "every set file carries asset and size; no two runs collide"))
    if args.markdown:
        args.markdown.write_text(table + "\n")


if __name__ == "__main__":
    main()
