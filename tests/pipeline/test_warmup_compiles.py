"""A first run as fast as the hundredth: after ``barkgen warm-up`` no front end compiles a numba
kernel. In a fresh numba cache (``NUMBA_CACHE_DIR``), the warm-up runs in one process, then
another runs what the front ends run, at other sizes and aspects than the warm-up's and from
other photos: the Python API's ``generate`` (non-square, not tiled, from a 16-bit photo and
from a grey one), the web app's server (the photo's crack network and its bark kinds, a crack
edit, the relief editor) and its worker's jobs (:func:`~barkgen.web.worker.run_labels`, then
:func:`~barkgen.web.worker.run_job` with that label map, tiled and not, with the material set,
cracks from an edited network, a bi-layer texture, another seed from the analysis cache on
disk), and a batch on a LocalCluster of one worker process. It counts numba's ``numba:compile``
events (a compile, never a load from the cache) in that process, and the cache's files, which
any process that compiles writes (the batch's worker)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

#: what the front ends run, in a process of its own; prints the compiles as one JSON line
FRONT_ENDS = r"""
import json, sys
from collections import OrderedDict
from pathlib import Path

import numpy as np
from numba.core import event

compiled = []


class Listener(event.Listener):
    def on_start(self, ev):
        func = ev.data["dispatcher"].py_func
        compiled.append(f"{func.__module__}.{func.__qualname__} {ev.data['args']}"[:300])

    def on_end(self, ev):
        pass


event.register("numba:compile", Listener())

from barkgen.branching import Structure, extend_branch, extract_structure, nearest_branch
from barkgen.data import sample_exemplar_path
from barkgen.io import decode_image, encode_png, read_image
from barkgen.material import Boundary, HeightEditor
from barkgen.pipeline import GenerateOptions, generate
from barkgen.web.worker import Done, JobSpec, LabelSpec, run_job, run_labels

work = Path(sys.argv[1])
sample = read_image(sample_exemplar_path())
photo = np.ascontiguousarray(sample[600:792, 200:456])  # 192 x 256, another part of the sample
seen = {}


def mark(what):
    seen[what] = len(compiled)


# the Python API: non-square, not tiled, from a 16-bit photo and from a grey one
generate(photo.astype(np.uint16) * 257, GenerateOptions(size=(72, 136), seed=3, material=True))
generate(photo[..., :1].copy(), GenerateOptions(size=(104, 64), tile=True, seed=4))
mark("api")

# the web app's server: the crack view and bark kinds, an edit of the network
png = encode_png(photo)
network = extract_structure(decode_image(png, "photo"))
edited = Structure.from_dict(json.loads(json.dumps(network.to_dict())), "structure")
index, _ = nearest_branch(edited, edited.branches[0].xy[0])
edited = extend_branch(edited, index, (3.0, 3.0), end="start")
mark("server")

# the web app's worker: the label map, then jobs
sent = []
run_labels(LabelSpec("labels", png, 3), sent.append)
assert isinstance(sent[-1], Done), sent[-1]
labels = sent[-1].files["labels_in.png"]


def job(options, **extra):
    sent.clear()
    run_job(JobSpec("job", png, "hash", "photo", options, "set", **extra), OrderedDict(), sent.append)
    assert isinstance(sent[-1], Done), sent[-1]
    return sent[-1].files


files = job({"size": (96, 160), "seed": 5, "material": True}, labels_in=labels)
job({"size": (112, 80), "seed": 6, "tile": True}, labels_in=labels)
job({"size": (96, 160), "seed": 7, "material": True}, labels_in=labels)  # the analysis from the disk
job({"size": (120, 88), "seed": 8, "tile": True, "structure": "cracks"}, crack_structure=edited.to_dict())
job({"size": (80, 120), "seed": 9, "tile": True, "material": True, "model": "bilayer"})
mark("worker")

# the web app's server: the relief editor on a result's files
name = next(n for n in files if n.endswith("_Displacement.png"))[: -len("_Displacement.png")]
height = decode_image(files[f"{name}_Displacement.png"], "displacement").astype(np.float32)
out_labels = decode_image(files["labels_out.png"], "labels")
editor = HeightEditor(decode_image(files["texture.png"], "texture"), height[..., 0], out_labels[..., 0], boundary=Boundary(False))
editor.edit(30, 40, 2.0, 5, 0.4)
mark("relief")

# a batch on a LocalCluster of one worker process (its compiles show in the cache's files)
from barkgen.batch import parse_spec, run_batch
from barkgen.io import write_png

write_png(work / "photo.png", photo[:160, :160])
spec = parse_spec(
    {"size": "88x120", "tile": True, "material": True, "exemplars": [{"name": "p", "path": "photo.png", "seeds": [1]}]},
    work,
)
report = run_batch(spec, work / "batch", workers=1, threads=1)
assert not report.failed, report.failed
mark("batch")
print(json.dumps({"compiled": compiled, "marks": seen}))
"""


def _cache_files(folder: Path) -> dict[str, int]:
    return {str(p.relative_to(folder)): p.stat().st_mtime_ns for p in folder.rglob("*.nb[ic]")}


def test_no_front_end_compiles_after_the_warm_up(tmp_path):
    numba_cache = tmp_path / "numba"
    env = {
        **os.environ,
        "NUMBA_CACHE_DIR": str(numba_cache),
        "BARKGEN_CACHE_DIR": str(tmp_path / "analyses"),  # the analyses are made, then read back
    }
    env.pop("BARKGEN_NO_CACHE", None)
    warm = subprocess.run(
        [sys.executable, "-m", "barkgen", "warm-up", "--quiet"], env=env, capture_output=True, text=True, timeout=600
    )
    assert warm.returncode == 0 and warm.stderr == "", warm.stderr
    warmed = _cache_files(numba_cache)
    assert warmed
    run = subprocess.run(
        [sys.executable, "-c", FRONT_ENDS, str(tmp_path)], env=env, capture_output=True, text=True, timeout=600
    )
    assert run.returncode == 0, run.stderr[-3000:]
    answer = json.loads(run.stdout.strip().splitlines()[-1])
    assert answer["compiled"] == [], (answer["marks"], answer["compiled"])
    written = sorted(name for name, stamp in _cache_files(numba_cache).items() if warmed.get(name) != stamp)
    assert written == []
    assert "compiling barkgen's numba kernels" not in run.stderr
