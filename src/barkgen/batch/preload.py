"""Dask worker preload: ``dask worker ... --preload barkgen.batch.preload`` (the local cluster
of :func:`barkgen.batch.local_cluster` does it too). Importing barkgen's stages and their heavy
libraries (scikit-learn, SciPy, OpenCV, faiss: about 3 s) when the worker starts, instead of in
its first task, keeps that one-time cost out of the batch: a worker serves every batch sent to
it, and one restarted after a crash is ready before it takes work.

A worker of barkgen's own local cluster (``BARKGEN_LOCAL_WORKER`` set by
:func:`barkgen.batch.local_cluster`) ignores SIGINT: Ctrl-C in a terminal reaches the whole
process group, and the ``barkgen batch`` that owns the workers stops them itself, with one
line, instead of every worker printing its traceback. A worker started by hand keeps its Ctrl-C.
"""

import os
import signal

import cv2  # noqa: F401
import faiss  # noqa: F401
import sklearn.cluster  # noqa: F401

import barkgen.io  # noqa: F401
import barkgen.labels  # noqa: F401
import barkgen.material  # noqa: F401
import barkgen.pipeline  # noqa: F401
import barkgen.shapes  # noqa: F401
import barkgen.synth  # noqa: F401

if os.environ.get("BARKGEN_LOCAL_WORKER") == "1":
    signal.signal(signal.SIGINT, signal.SIG_IGN)
