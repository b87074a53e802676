"""The thread pools of the libraries barkgen calls, sized so that they never fight.

A run calls numba kernels, faiss (OpenMP), OpenCV and BLAS one after the other, never at once,
so each of them may use every core while it works. BLAS is the exception: barkgen gives it only
small problems (the covariance and the 300 x 300 eigen-decomposition of a neighbourhood PCA, a
3-column colour product), and OpenBLAS' pool waits for work by spinning; beside other busy
processes (batch workers, the web app's worker, a desktop) its threads then collapsed: the
eigen-decomposition that takes 0.013 s on a quiet machine took 1 s a call. One BLAS thread
costs a quiet run nothing it would notice.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any


def _cores() -> int:
    import numba

    return int(numba.config.NUMBA_NUM_THREADS)  # type: ignore[attr-defined]  # numba sets its config at run time


@contextmanager
def thread_budget(threads: int | None = None) -> Iterator[int]:
    """Within the block, numba, faiss, OpenCV and SciPy's FFTs use ``threads`` threads each
    (default: every core numba may use, at most that many) and BLAS one; the previous counts
    come back after. (The FFTs' threads share out independent 1-D transforms: the same bytes
    for any count.)

    Parameters
    ----------
    threads : int, optional
        Threads for the parallel stages.

    Yields
    ------
    int
        The thread count in force.
    """
    import cv2
    import faiss
    import numba
    import scipy.fft
    from threadpoolctl import threadpool_limits

    from barkgen._shared.compile_notice import watch

    watch()  # a word when the kernels about to run compile (a cold cache)
    n = min(threads or _cores(), _cores())
    saved = numba.get_num_threads(), cv2.getNumThreads(), faiss.omp_get_max_threads()
    # BLAS first: faiss's own OpenBLAS is an OpenMP build, whose thread count is OpenMP's, so
    # faiss's count set after it holds for both (faiss's searches are the big problems it gets)
    with threadpool_limits(limits=1, user_api="blas"), scipy.fft.set_workers(n):
        numba.set_num_threads(n)
        cv2.setNumThreads(n)
        faiss.omp_set_num_threads(n)
        try:
            yield n
        finally:
            numba.set_num_threads(saved[0])
            cv2.setNumThreads(saved[1])
            faiss.omp_set_num_threads(saved[2])


def in_budget(threads: int | None, function, /, *args, **kwargs):
    """``function(*args, **kwargs)`` under :func:`thread_budget` (``threads``): for work handed
    to another thread, since numba's, OpenMP's and SciPy's FFT thread counts belong to the
    thread that sets them (a new thread starts with the defaults)."""
    with thread_budget(threads):
        return function(*args, **kwargs)


#: jobs on maps larger than this (pixels) run one after the other in :func:`side_by_side`:
#: each holds several float64 copies of its map (a screened Poisson solve of a 4096^2 map:
#: about 1 GB), so side by side they would add up (4096^2 material set: peak 3.2 -> 4.5 GiB)
SIDE_BY_SIDE_PIXELS = 2048 * 2048


@contextmanager
def worker_pool(workers: int) -> Iterator[Any]:
    """A :class:`concurrent.futures.ThreadPoolExecutor` of ``workers`` threads that, left by an
    exception (Ctrl-C's ``KeyboardInterrupt`` above all), drops the jobs not started and does not
    wait for the running ones: the caller unwinds at once instead of after the longest job (a
    2048² relief solve: 2.4 s). Its jobs compute in memory and write no file, so what they leave
    unfinished is lost with the process (the CLI ends an interrupted run without waiting for
    them, :func:`barkgen.cli.main`); an embedding caller's threads finish their jobs by
    themselves. Left normally, it waits for every job, as the executor does."""
    from concurrent.futures import ThreadPoolExecutor

    pool = ThreadPoolExecutor(max_workers=workers)
    try:
        yield pool
    except BaseException:
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown(wait=True)


def side_by_side(jobs: Sequence[Callable[[], Any]], threads: int | None = None, pixels: int = 0) -> list[Any]:
    """The results of independent ``jobs`` (callables without arguments, each reading only what
    it was given), run on a pool of at most ``threads`` threads (default: the cores numba may
    use in the calling thread), each under :func:`thread_budget` of its share of them; in the
    jobs' order. Work whose parts are small or one-threaded (a coarse level, a numpy
    expression, an FFT of one channel) keeps two cores busy better so than each part alone;
    every job computes what it would alone, to the byte. Jobs on maps of more than
    :data:`SIDE_BY_SIDE_PIXELS` ``pixels`` run one after the other (memory)."""
    import numba

    cores = min(threads or numba.get_num_threads(), _cores())
    workers = 1 if pixels > SIDE_BY_SIDE_PIXELS else max(1, min(cores, len(jobs)))
    if workers == 1:
        return [job() for job in jobs]
    share = max(1, cores // workers)
    with worker_pool(workers) as pool:
        futures = [pool.submit(in_budget, share, job) for job in jobs]
        return [future.result() for future in futures]


#: OpenCV's Gaussian blur with a wider sigma than this (px) runs faster on one thread: its
#: threaded path is another, slower one (sigma 64 on a 1538^2 float32 image: 0.55 s on one
#: thread, 0.86 s on two; sigma 32: 0.07 s against 0.17 s; sigma 8: 0.014 s against 0.009 s;
#: the same bytes either way)
ONE_THREAD_BLUR_SIGMA = 10.0

_opencv_lock = threading.Lock()
_opencv_single: list = [0, 1]  # [blocks inside, the thread count to restore]


@contextmanager
def opencv_one_thread() -> Iterator[None]:
    """Within the block, OpenCV runs on one thread (its count is the process's, so nested and
    concurrent blocks count themselves in and the last one out restores it); for the calls
    that run faster so (:data:`ONE_THREAD_BLUR_SIGMA`), several of which may run side by
    side (:func:`side_by_side`)."""
    import cv2

    with _opencv_lock:
        if _opencv_single[0] == 0:
            _opencv_single[1] = cv2.getNumThreads()
            cv2.setNumThreads(1)
        _opencv_single[0] += 1
    try:
        yield
    finally:
        with _opencv_lock:
            _opencv_single[0] -= 1
            if _opencv_single[0] == 0:
                cv2.setNumThreads(_opencv_single[1])
