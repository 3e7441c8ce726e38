"""The runs of a campaign folder identified one after the other in this
process, or spread over worker processes.

A worker reads the traces of its runs itself: only file names go out and one
:class:`Identification` per run comes back. Results come in run order and
are the same either way: every run is identified by the same code on the
same samples with single-threaded BLAS (threads would oversubscribe the
cores the workers use, change the rounding with their number, and do not
pay on the small dense matrices of a run). Workers are forked on Linux
(they inherit the loaded modules; spawned elsewhere).
"""
from __future__ import annotations

import multiprocessing
import os
import sys
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from typing import Any

from threadpoolctl import threadpool_limits

from structbench.identifier.errors import IdentificationError
from structbench.identifier.io.results import Identification
from structbench.identifier.io.traces import read_trace
from structbench.models import Model

from .methods import Method, method

BLAS_THREADS = 1
_WORKER: dict[str, Any] = {}  # this worker's method, model, options and BLAS limits


def available_cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def identify_run(chosen: Method, model: Model | None, settings: Mapping[str, Any],
                 paths: Sequence[Path]) -> Identification:
    """Read the traces of one run (in the given order) and identify them."""
    return chosen.call([read_trace(p) for p in paths], model, **settings)


def _start(method_name: str, model: Model | None, settings: dict[str, Any]) -> None:
    _WORKER.update(method=method(method_name), model=model, settings=settings,
                   limits=threadpool_limits(BLAS_THREADS, "blas"))


def _identify(paths: list[Path]) -> Identification:
    return identify_run(_WORKER["method"], _WORKER["model"], _WORKER["settings"], paths)


def identify_runs(runs: Sequence[Sequence[Path]], chosen: Method, model: Model | None,
                  settings: Mapping[str, Any], jobs: int | None = None,
                  progress: Callable[[int, int], None] | None = None) -> list[Identification]:
    """One :class:`Identification` per run (the trace files of each), in run
    order, on ``jobs`` processes (default: one per available core; 1, or
    when this process is a daemon: in this process). ``progress`` receives
    (runs done, runs in all) after every run."""
    jobs = available_cores() if jobs is None else jobs
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise IdentificationError(f"must be a whole number of at least 1, got {jobs!r}", field="--jobs")
    results: list[Identification] = []

    def finished(result: Identification) -> None:
        results.append(result)
        if progress is not None:
            progress(len(results), len(runs))

    workers = min(jobs, len(runs))
    if workers <= 1 or multiprocessing.current_process().daemon:  # a daemon (a pool's worker) has no children
        with threadpool_limits(BLAS_THREADS, "blas"):
            for paths in runs:
                finished(identify_run(chosen, model, settings, paths))
        return results
    context = multiprocessing.get_context("fork" if sys.platform.startswith("linux") else None)
    pool = ProcessPoolExecutor(workers, mp_context=context, initializer=_start,
                               initargs=(chosen.name, model, dict(settings)))
    try:
        futures = [pool.submit(_identify, list(paths)) for paths in runs]
        for future in futures:
            finished(future.result())
    except BrokenProcessPool:
        raise IdentificationError("a worker process died (out of memory?); try fewer jobs",
                                  field="--jobs") from None
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
    return results
