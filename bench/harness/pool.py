"""Where a campaign's tasks run: local worker processes (warm pool, one FMU
instance per worker, reset between tests) or an existing Dask cluster, and
the worker-side entry point :func:`trace_task`. Either way a task runs in a
:class:`.child.Child`, a Python started by :mod:`subprocess` that never
imports the caller's ``__main__``.
"""
from __future__ import annotations

import atexit
import dataclasses
import os
import queue
import tempfile
import threading
from collections.abc import Callable, Iterable
from concurrent.futures import FIRST_COMPLETED, Future, wait
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
    key = (bench.fmu_sha256, tuple(sorted(bench.parameters.items())), bench.options.interface,
           bench.options.relative_tolerance)
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
    limit). Workers write trace files themselves.

    Each worker is a thread of this process driving its own
    :class:`.child.Child`, started on the thread's first task and kept warm.
    A child that dies fails only its own task, with its signal or exit code
    (:meth:`death`); :meth:`restart` kills the children running a task."""

    writes_files = True
    entry = staticmethod(trace_task)  # what runs a task on a worker

    def __init__(self, jobs: int):
        self.jobs = jobs
        self._tasks: queue.SimpleQueue[tuple[Future, int, Callable, tuple] | None] = queue.SimpleQueue()
        self._lock = threading.Lock()
        self._generation = 0         # bumped by restart: older tasks not yet started never start
        self._busy: set[Child] = set()  # children running a task
        self._failure = "the worker process died"
        self._threads = [threading.Thread(target=self._work, name=f"structbench-worker-{i}", daemon=True)
                         for i in range(jobs)]
        for thread in self._threads:
            thread.start()

    @property
    def size(self) -> int:
        return max(self.jobs, 1)

    @property
    def can_stop(self) -> bool:
        """Whether :meth:`restart` can stop a task that runs too long."""
        return self.jobs > 0

    def submit(self, fn: Callable, *args: Any) -> Future:
        future: Future = Future()
        if self.jobs == 0:
            future.set_result(fn(*args))
        else:
            self._tasks.put((future, self._generation, fn, args))
        return future

    def _work(self) -> None:
        """A worker thread: each task in this thread's child, started when
        there is none or it died; the child exits when the pool closes."""
        child: Child | None = None
        while (item := self._tasks.get()) is not None:
            future, generation, fn, args = item
            if not future.set_running_or_notify_cancel():
                continue
            try:
                if child is None or not child.alive:
                    if child is not None:
                        child.close()
                    child = Child()
                future.set_result(self._call(child, generation, fn, args))
            except Exception as err:  # noqa: BLE001 - the child died (ChildDied) or could not start
                with self._lock:
                    if generation == self._generation:
                        self._failure = str(err)
                future.set_exception(err)
        if child is not None and child.alive:
            child.stop()

    def _call(self, child: Child, generation: int, fn: Callable, args: tuple) -> Any:
        """``fn(*args)`` in ``child``, unless :meth:`restart` came since the task was submitted."""
        with self._lock:
            if generation != self._generation:
                raise ChildDied("the workers were restarted")
            self._busy.add(child)
        try:
            return child.call(fn, args, None)
        finally:
            with self._lock:
                self._busy.discard(child)

    def wait(self, futures: Iterable[Future], timeout: float | None = None) -> set[Future]:
        return wait(list(futures), timeout=timeout, return_when=FIRST_COMPLETED).done

    def death(self) -> str:
        """Why the last task failed: the signal or exit status of its child
        (``crashed with signal 11``), read by the thread that owned it."""
        return self._failure

    def restart(self) -> None:
        """Kill the children running a task (one hangs); tasks submitted
        before never start. Idle children stay warm."""
        with self._lock:
            self._generation += 1
            for child in self._busy:
                child.process.kill()
                child.process.wait()

    def share(self, obj: Any) -> Any:
        return obj

    def share_fmu(self, fmu: Path) -> None:
        """Workers read the FMU from this machine's file system: nothing to send."""
        return None

    def close(self) -> None:
        """Stop the workers: a running task is killed, idle children exit on their own."""
        self.restart()
        for _ in self._threads:
            self._tasks.put(None)
        for thread in self._threads:
            thread.join()


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
