"""Batch generation of many unique barks on Dask (mazzolini2012 §3.1.1: every tree has its own
bark): a spec of photos and seeds (:func:`load_spec`), run on an embedded LocalCluster or any
Dask cluster (:func:`run_batch`), each photo analysed once and shared with the workers, every
variant written atomically and recorded in a manifest that a re-run resumes from."""

from barkgen.batch.manifest import MANIFEST_NAME, Manifest
from barkgen.batch.runner import BatchReport, local_cluster, run_batch
from barkgen.batch.spec import BatchSpec, ExemplarJob, load_spec, parse_spec

__all__ = [
    "MANIFEST_NAME",
    "BatchReport",
    "BatchSpec",
    "ExemplarJob",
    "Manifest",
    "load_spec",
    "local_cluster",
    "parse_spec",
    "run_batch",
]
