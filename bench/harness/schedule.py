"""Schedule a campaign's tests on a pool and book what comes back.

Tests are split into tasks: a test without actuator noise simulates once and
its sensor-noise repetitions are spread over the workers in chunks that reuse
that simulation; with actuator noise or a per-repetition random force every
repetition is a task of its own.
Finished traces are written into the folder and the status updated after
every task.
"""
from __future__ import annotations

import math
import time
from collections import deque
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

from .fmu_setup import Bench
from .folder import CampaignStatus, Folder
from .pool import Pool
from .simulation import Outcome
from .test_entries import TestSpec

MAX_CHUNK = 10  # sensor-noise repetitions per task
STATUS_SECONDS = 1.0  # s: status.json is rewritten at most this often while tasks finish


@dataclass
class Task:
    """Repetitions of one test for one worker; ``record`` is a shared
    noise-free simulation to reuse; ``later`` are repetitions to spread over
    the workers once this task has returned the simulation."""

    test: TestSpec
    repetitions: list[int]
    record: Any = None
    later: list[int] = field(default_factory=list)


class Scheduler:
    """Launches the tasks of the missing traces, at most one per worker, and
    books their outcomes.

    When a worker process dies, every task it took down is retried alone,
    one at a time from then on, so only the task that kills its worker fails
    (with the signal that killed it). A task running longer than its test's
    ``timeout`` fails; local workers are then killed and restarted, and the
    other tasks they were running are launched again (Dask workers stop such
    a task themselves: :func:`.pool.guarded_trace_task`).
    """

    def __init__(self, pool: Pool, bench: Bench, folder: Folder, status: CampaignStatus, blob: Any,
                 progress: Callable[[CampaignStatus], None] | None):
        self.pool, self.bench, self.folder, self.status, self.blob = pool, bench, folder, status, blob
        self.progress = progress
        self.running: dict[Any, tuple[Task, bool, float]] = {}  # future -> (task, ran alone, start)
        self.queue: deque[Task] = deque()
        self.isolate = False
        self.out_dir = str(folder.traces) if pool.writes_files else None

    def submit(self, task: Task) -> None:
        self.queue.append(task)

    def _launch(self, task: Task) -> None:
        future = self.pool.submit(self.pool.entry, self.bench, task.test, task.repetitions, task.record,
                                  bool(task.later), self.out_dir, self.blob)
        self.running[future] = (task, self.isolate, time.monotonic())

    def _fill(self) -> None:
        """Launch queued tasks while a worker is free (only one at a time when isolating)."""
        room = 1 if self.isolate else self.pool.size
        while self.queue and len(self.running) < room:
            self._launch(self.queue.popleft())

    def plan(self, tests: Iterable[TestSpec]) -> None:
        """Queue the tasks of every trace not yet present."""
        for test in tests:
            st = self.status.tests[test.name]
            missing = [r for r in range(test.repetitions) if test.trace_name(r) not in st.present]
            if not missing:
                continue
            if test.simulates_each_repetition:
                for r in missing:
                    self.submit(Task(test, [r]))
            else:
                size = min(MAX_CHUNK, max(1, math.ceil(len(missing) / (4 * self.pool.size))))
                self.submit(Task(test, missing[:size], later=missing[size:]))

    def book(self, future: Any) -> None:
        task, alone, _ = self.running.pop(future)
        try:
            outcome = future.result()
        except Exception:  # the worker process died
            if not alone:
                self.isolate = True
                self.queue.appendleft(task)
                return
            outcome = Outcome(task.test.name, error=self.pool.death())
        self._record(task, outcome)

    def _record(self, task: Task, outcome: Outcome) -> None:
        st = self.status.tests[task.test.name]
        for name, image, digest in outcome.files:
            if image is not None:
                self.folder.write_trace(name, image)
            st.present.add(name)
            st.sha256[name] = digest
        if outcome.error is not None:
            st.error = st.error or outcome.error
        elif task.later:
            record = self.pool.share(outcome.record)
            size = min(MAX_CHUNK, max(1, math.ceil(len(task.later) / (2 * self.pool.size))))
            for i in range(0, len(task.later), size):
                self.submit(Task(task.test, task.later[i:i + size], record))

    def _next_deadline(self) -> float | None:
        """Seconds until the first running task exceeds its limit (None: no limit)."""
        if not self.pool.can_stop or not self.running:
            return None
        now = time.monotonic()
        return max(0.0, min(start + task.test.timeout - now for task, _, start in self.running.values()))

    def _stop_late(self) -> None:
        """Fail the tasks over their limit; restart the workers, relaunching the others."""
        now = time.monotonic()
        late = [f for f, (task, _, start) in self.running.items() if now - start >= task.test.timeout]
        if not late:
            return
        for future in late:
            task = self.running.pop(future)[0]
            self._record(task, Outcome(task.test.name, error=f"timed out after {task.test.timeout:g} s"))
        self.queue.extendleft(reversed([task for task, _, _ in self.running.values()]))
        self.running.clear()
        self.pool.restart()

    def run(self) -> None:
        """Run the queued tasks, booking each; ``status.json`` is rewritten at
        most every :data:`STATUS_SECONDS` (a trace written since is checked by
        its contents on resume; :func:`.run.run_campaign` writes the last one)."""
        written = time.monotonic()
        while self.running or self.queue:
            self._fill()
            done = self.pool.wait(self.running, self._next_deadline())
            for future in done:
                self.book(future)
            if not done:
                self._stop_late()
            if time.monotonic() - written >= STATUS_SECONDS:
                self.folder.write_status(self.status)
                written = time.monotonic()
            if self.progress is not None:
                self.progress(self.status)
