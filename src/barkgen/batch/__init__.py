"""Batch generation of many unique barks on Dask (mazzolini2012 §3.1.1: every tree has its own
bark): a spec of photos and seeds (:func:`load_spec`), run on an embedded LocalCluster or any
Dask cluster (:func:`run_batch`), each photo analysed once and shared with the workers, every
variant written atomically and recorded in a manifest that a re-run resumes from."""

from barkgen._shared.extras import require_extra

require_extra("batch", "batch generation")

from barkgen.batch.manifest import MANIFEST_NAME, Manifest  # noqa: E402
from barkgen.batch.runner import BatchReport, local_cluster, run_batch  # noqa: E402
from barkgen.batch.spec import BatchSpec, ExemplarJob, load_spec, parse_spec  # noqa: E402

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
