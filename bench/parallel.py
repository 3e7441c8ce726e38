"""Run a campaign's tests in parallel: local worker processes (warm pool, one
FMU instance per worker, reset between tests) or an existing Dask cluster.

:func:`run_campaign` is the entry point. Tests are split into tasks: a test
without actuator noise simulates once and its sensor-noise repetitions are
spread over the workers in chunks that reuse that simulation; with actuator
noise every repetition is a task of its own.
"""
from __future__ import annotations

import atexit
import dataclasses
import math
import multiprocessing
import multiprocessing.util
import os
import tempfile
import threading
from collections import deque
from collections.abc import Callable, Iterable
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from models.errors import UserError

from .campaign import Campaign, TestSpec, load_campaign
from .external import fmu_variables
from .folder import CampaignStatus, Folder
from .runner import Bench, Outcome, Record, Rig, run_test
from .truth import impulse_states, truth

MAX_CHUNK = 10  # sensor-noise repetitions per task

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


# ---- pools -----------------------------------------------------------------
class LocalPool:
    """``jobs`` worker processes (0: run in this process). Workers write
    trace files themselves."""

    writes_files = True

    def __init__(self, jobs: int):
        self.jobs = jobs
        self._executor = self._start() if jobs > 0 else None

    def _start(self) -> ProcessPoolExecutor:
        context = multiprocessing.get_context("forkserver")
        context.set_forkserver_preload(["bench.runner", "bench.fmu_driver"])
        return ProcessPoolExecutor(self.jobs, mp_context=context)

    @property
    def size(self) -> int:
        return max(self.jobs, 1)

    def submit(self, fn: Callable, *args: Any) -> Future:
        if self._executor is None:
            future: Future = Future()
            future.set_result(fn(*args))
            return future
        try:
            return self._executor.submit(fn, *args)
        except BrokenProcessPool:  # a worker died (e.g. the FMU crashed it): start afresh
            self._executor.shutdown(wait=False, cancel_futures=True)
            self._executor = self._start()
            return self._executor.submit(fn, *args)

    def wait(self, futures: Iterable[Future]) -> set[Future]:
        return wait(list(futures), return_when=FIRST_COMPLETED).done

    def share(self, obj: Any) -> Any:
        return obj

    def close(self) -> None:
        if self._executor is not None:
            self._executor.shutdown(wait=True, cancel_futures=True)


class DaskPool:
    """The workers of an existing Dask distributed cluster. Trace images come
    back to this process, which writes them; the FMU file is sent to the
    workers once, so they need no shared file system (only structbench)."""

    writes_files = False

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

    def wait(self, futures: Iterable[Any]) -> set[Any]:
        from distributed import wait as dask_wait

        return dask_wait(list(futures), return_when="FIRST_COMPLETED").done

    def share(self, obj: Any) -> Any:
        return self.client.scatter(obj, broadcast=True)

    def close(self) -> None:
        self.client.close()


Pool = LocalPool | DaskPool


def make_pool(jobs: int | None, scheduler: str | None) -> Pool:
    """A Dask pool for ``scheduler``, else ``jobs`` local workers (default: one per CPU)."""
    if scheduler:
        return DaskPool(scheduler)
    return LocalPool((os.cpu_count() or 1) if jobs is None else jobs)


# ---- campaign --------------------------------------------------------------
def prepare_fmu(campaign: Campaign, fmu_dir: Path) -> Path:
    """The FMU to run: the external one, or the structure's (built if missing)."""
    if campaign.fmu is not None:
        return campaign.fmu
    from models.fmu import build_fmu

    return build_fmu(campaign.model, fmu_dir)


def make_bench(campaign: Campaign, fmu: Path, sha256: str) -> Bench:
    nodes = {c.node for t in campaign.tests for c in t.channels} | {
        i.node for t in campaign.tests for i in t.excitation}
    return Bench(campaign.name, campaign.structure, str(fmu), sha256, dict(campaign.parameters), campaign.mapping,
                 {n: campaign.location(n) for n in sorted(nodes)},
                 impulse_states(campaign) if campaign.model is not None else {})


@dataclass
class _Task:
    """Repetitions of one test for one worker; ``record`` is a shared
    noise-free simulation to reuse; ``later`` are repetitions to spread over
    the workers once this task has returned the simulation."""

    test: TestSpec
    repetitions: list[int]
    record: Any = None
    later: list[int] = field(default_factory=list)


class _Scheduler:
    """Submits the tasks of the missing traces and books their outcomes.

    When a worker process dies, every task it took down is retried alone,
    one at a time from then on, so only the task that kills its worker fails.
    """

    def __init__(self, pool: Pool, bench: Bench, folder: Folder, status: CampaignStatus, blob: Any,
                 progress: Callable[[CampaignStatus], None] | None):
        self.pool, self.bench, self.folder, self.status, self.blob = pool, bench, folder, status, blob
        self.progress = progress
        self.running: dict[Any, tuple[_Task, bool]] = {}  # future -> (task, ran alone)
        self.queue: deque[_Task] = deque()
        self.isolate = False
        self.out_dir = str(folder.traces) if pool.writes_files else None

    def submit(self, task: _Task) -> None:
        if self.isolate:
            self.queue.append(task)
            return
        self._launch(task)

    def _launch(self, task: _Task) -> None:
        future = self.pool.submit(trace_task, self.bench, task.test, task.repetitions, task.record,
                                  bool(task.later), self.out_dir, self.blob)
        self.running[future] = (task, self.isolate)

    def start(self, tests: Iterable[TestSpec]) -> None:
        for test in tests:
            st = self.status.tests[test.name]
            missing = [r for r in range(test.repetitions) if test.trace_name(r) not in st.present]
            if not missing:
                continue
            if test.noise.actuator:
                for r in missing:
                    self.submit(_Task(test, [r]))
            else:
                size = min(MAX_CHUNK, max(1, math.ceil(len(missing) / (4 * self.pool.size))))
                self.submit(_Task(test, missing[:size], later=missing[size:]))

    def book(self, future: Any) -> None:
        task, alone = self.running.pop(future)
        try:
            outcome = future.result()
        except Exception as err:  # the worker process died
            if not alone:
                self.isolate = True
                self.queue.append(task)
                return
            outcome = Outcome(task.test.name, error=f"the worker process died ({type(err).__name__}: {err})")
        st = self.status.tests[task.test.name]
        for name, image in outcome.files:
            if image is not None:
                self.folder.write_trace(name, image)
            st.present.add(name)
        if outcome.error is not None:
            st.error = st.error or outcome.error
        elif task.later:
            record = self.pool.share(outcome.record)
            size = min(MAX_CHUNK, max(1, math.ceil(len(task.later) / (2 * self.pool.size))))
            for i in range(0, len(task.later), size):
                self.submit(_Task(task.test, task.later[i:i + size], record))

    def run(self) -> None:
        while self.running or self.queue:
            if not self.running:
                self._launch(self.queue.popleft())
            for future in self.pool.wait(self.running):
                self.book(future)
            self.folder.write_status(self.status)
            if self.progress is not None:
                self.progress(self.status)


def run_campaign(campaign: Campaign | str | Path, out: str | Path, jobs: int | None = None,
                 scheduler: str | None = None, fmu_dir: str | Path | None = None,
                 progress: Callable[[CampaignStatus], None] | None = None) -> CampaignStatus:
    """Run (or resume) a campaign into the folder ``out``.

    ``jobs``: local worker processes (default one per CPU; 0 runs in this
    process); ``scheduler``: address of a Dask scheduler instead; ``fmu_dir``:
    where a built-in structure's FMU is built (default ``out/fmus``);
    ``progress`` is called with the status after every finished task.
    Everything is validated before the first simulation. Returns the final
    status; ``status.failed`` tests are listed with their errors in
    ``out/status.json``.
    """
    from .fmu_driver import fmu_checksum

    if not isinstance(campaign, Campaign):
        campaign = load_campaign(campaign)
    folder = Folder(out)
    folder.prepare(campaign)
    fmu = prepare_fmu(campaign, Path(fmu_dir) if fmu_dir else folder.root / "fmus")
    campaign.check_variables(fmu_variables(fmu), fmu.name)
    sha256 = fmu_checksum(fmu)
    folder.write_truth(truth(campaign))
    status = folder.status(campaign, fmu, sha256)
    folder.write_status(status)
    pool = make_pool(jobs, scheduler)
    try:
        blob = pool.share(fmu.read_bytes()) if isinstance(pool, DaskPool) else None
        scheduler_ = _Scheduler(pool, make_bench(campaign, fmu, sha256), folder, status, blob, progress)
        scheduler_.start(campaign.tests)
        if progress is not None:
            progress(status)
        scheduler_.run()
    finally:
        pool.close()
    return status
