"""Where a campaign's tasks run: local worker processes (warm pool, one FMU
instance per worker, reset between tests) or an existing Dask cluster, and
the worker-side entry point :func:`trace_task`.
"""
from __future__ import annotations

import atexit
import dataclasses
import multiprocessing
import multiprocessing.util
import os
import signal
import tempfile
import threading
from collections.abc import Callable, Iterable
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from typing import Any

from structbench.models.errors import UserError

from .child import Child, ChildDied, TimedOut
from .fmu_setup import Bench
from .simulation import Outcome, Record, Rig, run_test
from .test_entries import TestSpec

# ---- worker side -----------------------------------------------------------
_LOCAL = threading.local()  # this worker's FMU instance (per thread: Dask may run threads)
_OPEN: list[Rig] = []       # every instance this process opened, closed at exit


def _close_all() -> None:
    while _OPEN:
        _OPEN.pop().close()


atexit.register(_close_all)
multiprocessing.util.Finalize(None, _close_all, exitpriority=10)  # pool workers skip atexit


def _fmu_file(bench: Bench, blob: bytes | None) -> str:
    """The FMU on this machine: the campaign's path, or ``blob`` saved locally."""
    if blob is None or Path(bench.fmu).is_file():
        return bench.fmu
    path = Path(tempfile.gettempdir()) / f"structbench-{bench.fmu_sha256[:16]}-{bench.fmu_name}"
    if not path.is_file():
        tmp = path.with_suffix(f".{os.getpid()}.part")
        tmp.write_bytes(blob)
        tmp.replace(path)
    return str(path)


def _rig(bench: Bench, blob: bytes | None) -> Rig:
    """This worker's FMU instance for ``bench``, opened on first use and kept
    (reset between tests) until a campaign with another set-up comes."""
    key = (bench.fmu_sha256, tuple(sorted(bench.parameters.items())))
    if getattr(_LOCAL, "key", None) != key:
        old = getattr(_LOCAL, "rig", None)
        if old is not None:
            _OPEN.remove(old)
            old.close()
        _LOCAL.key, _LOCAL.rig = None, None
        _LOCAL.rig = Rig(dataclasses.replace(bench, fmu=_fmu_file(bench, blob)))
        _LOCAL.key = key
        _OPEN.append(_LOCAL.rig)
    return _LOCAL.rig


def trace_task(bench: Bench, test: TestSpec, repetitions: list[int], record: Record | None, keep_record: bool,
              out_dir: str | None, blob: bytes | None) -> Outcome:
    """Worker entry point: traces of some repetitions of one test."""
    try:
        rig = _rig(bench, blob)
    except Exception as err:
        return Outcome(test.name, error=f"{type(err).__name__}: {err}")
    return run_test(rig, bench, test, repetitions, record, keep_record, Path(out_dir) if out_dir else None)


def guarded_trace_task(bench: Bench, test: TestSpec, repetitions: list[int], record: Record | None,
                       keep_record: bool, out_dir: str | None, blob: bytes | None) -> Outcome:
    """Dask worker entry point: :func:`trace_task` in this worker thread's
    child process (:mod:`.child`), killed when it runs over the test's ``timeout``."""
    try:
        bench = dataclasses.replace(bench, fmu=_fmu_file(bench, blob))
        child = getattr(_LOCAL, "child", None)
        if child is None or not child.alive:
            child = _LOCAL.child = Child()
        return child.call(trace_task, (bench, test, repetitions, record, keep_record, out_dir, None), test.timeout)
    except TimedOut:
        return Outcome(test.name, error=f"timed out after {test.timeout:g} s")
    except ChildDied as err:
        return Outcome(test.name, error=str(err))
    except OSError as err:  # the FMU file or the child could not be set up on this worker
        return Outcome(test.name, error=f"{type(err).__name__}: {err}")


# ---- pools -----------------------------------------------------------------
class LocalPool:
    """``jobs`` worker processes (0: run in this process, without time
    limit). Workers write trace files themselves."""

    writes_files = True
    entry = staticmethod(trace_task)  # what runs a task on a worker

    def __init__(self, jobs: int):
        self.jobs = jobs
        self._executor = self._start() if jobs > 0 else None
        self._workers: dict[int, multiprocessing.Process] = {}

    def _start(self) -> ProcessPoolExecutor:
        context = multiprocessing.get_context("forkserver")
        context.set_forkserver_preload(["structbench.harness.simulation", "structbench.harness.fmu_session"])
        return ProcessPoolExecutor(self.jobs, mp_context=context)

    @property
    def size(self) -> int:
        return max(self.jobs, 1)

    @property
    def can_stop(self) -> bool:
        """Whether :meth:`restart` can stop a task that runs too long."""
        return self._executor is not None

    def submit(self, fn: Callable, *args: Any) -> Future:
        if self._executor is None:
            future: Future = Future()
            future.set_result(fn(*args))
            return future
        try:
            future = self._executor.submit(fn, *args)
        except BrokenProcessPool:  # a worker died (e.g. the FMU crashed it): start afresh
            self.restart()
            future = self._executor.submit(fn, *args)
        # the executor's own table of worker processes (kept to read exit codes)
        self._workers = self._executor._processes  # type: ignore[attr-defined]
        return future

    def wait(self, futures: Iterable[Future], timeout: float | None = None) -> set[Future]:
        return wait(list(futures), timeout=timeout, return_when=FIRST_COMPLETED).done

    def death(self) -> str:
        """Why a worker process died: the signal or exit code of the one that
        did not die by the pool's own hand. Read once the pool's own thread
        has reaped its workers: it fails the futures first and joins the
        processes after, and a forkserver process polled from two threads at
        once can lose its status to the other and report 255 (a segfault
        was reported as "exited with status 255" in one run of six)."""
        if self._executor is not None:
            self._executor.shutdown(wait=True)
        codes = [p.exitcode for p in list(self._workers.values()) if p.exitcode not in (None, -signal.SIGTERM)]
        if not codes:
            return "the worker process died"
        code = codes[0]
        return f"crashed with signal {-code}" if code < 0 else f"the worker process exited with status {code}"

    def restart(self) -> None:
        """Kill every worker (a task hangs, or one died) and start afresh."""
        if self._executor is None:
            return
        for process in list(self._workers.values()):
            if process.exitcode is None:
                process.kill()
        self._executor.shutdown(wait=True, cancel_futures=True)
        self._executor = self._start()
        self._workers = {}

    def share(self, obj: Any) -> Any:
        return obj

    def share_fmu(self, fmu: Path) -> None:
        """Workers read the FMU from this machine's file system: nothing to send."""
        return None

    def close(self) -> None:
        if self._executor is not None:
            self._executor.shutdown(wait=True, cancel_futures=True)


class DaskPool:
    """The workers of an existing Dask distributed cluster. Trace images come
    back to this process, which writes them; the FMU file is sent to the
    workers once, so they need no shared file system (only structbench).
    Each worker thread runs its tasks in a child process, which stops a task
    over its time limit (:func:`guarded_trace_task`)."""

    writes_files = False
    entry = staticmethod(guarded_trace_task)

    def __init__(self, address: str, timeout: float = 30.0):
        from distributed import Client

        try:
            self.client = Client(address, timeout=timeout)
        except (OSError, TimeoutError) as err:
            raise UserError(f"cannot connect to the Dask scheduler: {err}", field="--scheduler") from None

    @property
    def size(self) -> int:
        return max(sum(w["nthreads"] for w in self.client.scheduler_info()["workers"].values()), 1)

    def submit(self, fn: Callable, *args: Any) -> Any:
        return self.client.submit(fn, *args, pure=False)

    can_stop = False  # the workers stop a task over its limit themselves

    def wait(self, futures: Iterable[Any], timeout: float | None = None) -> set[Any]:
        from distributed import wait as dask_wait

        try:
            return dask_wait(list(futures), timeout=timeout, return_when="FIRST_COMPLETED").done
        except TimeoutError:
            return set()

    def death(self) -> str:
        return "the worker process died"

    def restart(self) -> None:
        """Nothing to restart: the cluster's workers are not this process's."""

    def share(self, obj: Any) -> Any:
        return self.client.scatter(obj, broadcast=True)

    def share_fmu(self, fmu: Path) -> Any:
        """The FMU file's bytes, sent once to every worker."""
        return self.share(fmu.read_bytes())

    def close(self) -> None:
        self.client.close()


Pool = LocalPool | DaskPool


def make_pool(jobs: int | None, scheduler: str | None) -> Pool:
    """A Dask pool for ``scheduler``, else ``jobs`` local workers (default: one per CPU)."""
    if scheduler:
        return DaskPool(scheduler)
    return LocalPool((os.cpu_count() or 1) if jobs is None else jobs)
