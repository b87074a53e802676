"""The web worker's analysis made ahead (issue 71): after a label job that carries the page's
default options, the worker makes their analysis from the label map; a job of the same analysis
takes it over (the same bytes as without it), a job of another is run at once instead."""

from __future__ import annotations

from collections import OrderedDict

import numpy as np
import pytest

from barkgen.data import sample_exemplar_path
from barkgen.io import encode_png, read_image
from barkgen.web.worker import Done, JobSpec, LabelSpec, job_analysis_key, prefetch_analysis, run_job, run_labels


class FakeConn:
    """A worker's pipe end: the messages waiting on it."""

    def __init__(self, *waiting) -> None:
        self.waiting = list(waiting)

    def poll(self) -> bool:
        return bool(self.waiting)

    def recv(self):
        return self.waiting.pop(0)


@pytest.fixture(scope="module")
def png() -> bytes:
    return encode_png(np.ascontiguousarray(read_image(sample_exemplar_path())[600:728, 200:328]))


def _labels(png: bytes, options: dict) -> tuple[LabelSpec, np.ndarray]:
    spec = LabelSpec("labels", png, options["k"], prefetch=options, photo_hash="hash")
    sent: list = []
    label_map = run_labels(spec, sent.append)
    assert isinstance(sent[-1], Done) and label_map is not None
    return spec, label_map


def _files(spec: JobSpec, analyses: OrderedDict) -> dict[str, bytes]:
    sent: list = []
    run_job(spec, analyses, sent.append)
    assert isinstance(sent[-1], Done), sent[-1]
    return dict(sent[-1].files)


def test_a_job_of_the_same_analysis_takes_it_over_with_the_same_bytes(png, monkeypatch):
    monkeypatch.setenv("BARKGEN_NO_CACHE", "1")
    options = {"size": (64, 64), "k": 3, "seed": 0}
    spec, label_map = _labels(png, options)
    job = JobSpec("job", png, "hash", "photo", {**options, "seed": 5}, "set", labels_in=encode_png(label_map))
    analyses: OrderedDict = OrderedDict()
    # the job arrives while the analysis is made: it goes on, and the job comes back to be run
    assert prefetch_analysis(spec, label_map, analyses, FakeConn(job)) == [job]
    from barkgen.pipeline import GenerateOptions

    assert list(analyses) == [job_analysis_key("hash", GenerateOptions(**options), labels=label_map)]
    ahead, made = _files(job, analyses), _files(job, OrderedDict())
    assert len(analyses) == 1  # the job took the analysis over (its label map, read back, is the same)
    del ahead["report.json"], made["report.json"]  # its timings differ (its digests are in the files)
    assert ahead == made


def test_a_job_of_another_analysis_stops_it(png, monkeypatch):
    monkeypatch.setenv("BARKGEN_NO_CACHE", "1")
    options = {"size": (64, 64), "k": 3, "seed": 0}
    spec, label_map = _labels(png, options)
    other = JobSpec("job", png, "hash", "photo", {**options, "size": (48, 48)}, "set")
    analyses: OrderedDict = OrderedDict()
    assert prefetch_analysis(spec, label_map, analyses, FakeConn(other)) == [other]
    assert not analyses
    # the worker told to end (None) ends it too, and is handed back
    assert prefetch_analysis(spec, label_map, analyses, FakeConn(None)) == [None]
    assert not analyses


def test_served_an_upload_queues_its_label_map_with_the_page_defaults_analysis(png, tmp_path):
    """``barkgen serve``'s way (eager): a new photo's label job is queued by its upload and
    carries the page's default options; a label map of other k carries none."""
    from fastapi.testclient import TestClient

    from barkgen.library import Library
    from barkgen.web import create_app
    from barkgen.web.routes_jobs import page_default_options

    app = create_app(Library(tmp_path / "lib"), run_jobs=False)
    app.state.barkgen.jobs.eager = True
    with TestClient(app) as client:
        exemplar = client.post("/api/exemplars", files={"file": ("bark.png", png)}).json()["id"]
        (job,) = client.get("/api/jobs").json()
        assert job["kind"] == "labels" and job["params"]["k"] == page_default_options()["k"]
        assert app.state.barkgen.jobs.get(job["id"]).spec == {"options": page_default_options()}
        # the page asks for it again: the same job
        assert client.post(f"/api/exemplars/{exemplar}/labels?k=3").json()["job"]["id"] == job["id"]
        other = client.post(f"/api/exemplars/{exemplar}/labels?k=4").json()["job"]["id"]
        assert app.state.barkgen.jobs.get(other).spec == {}


def test_another_label_map_of_the_same_photo_is_another_analysis(png, monkeypatch):
    """The worker keeps analyses by photo, options and the label map given: a job with the
    user's own label map does not take the analysis made from the photo's."""
    monkeypatch.setenv("BARKGEN_NO_CACHE", "1")
    options = {"size": (64, 64), "k": 3, "seed": 0}
    spec, label_map = _labels(png, options)
    analyses: OrderedDict = OrderedDict()
    _files(JobSpec("a", png, "hash", "photo", options, "set", labels_in=encode_png(label_map)), analyses)
    flipped = np.ascontiguousarray(label_map[:, ::-1])
    _files(JobSpec("b", png, "hash", "photo", options, "set", labels_in=encode_png(flipped)), analyses)
    assert len(analyses) == 2
