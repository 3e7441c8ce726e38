"""Schedule a campaign's tests on a pool and book what comes back.

Tests are split into tasks: a test without actuator noise simulates once and
its sensor-noise repetitions are spread over the workers in chunks that reuse
that simulation; with actuator noise every repetition is a task of its own.
Finished traces are written into the folder and the status updated after
every task.
"""
from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

from .fmu_setup import Bench
from .folder import CampaignStatus, Folder
from .pool import Pool, trace_task
from .simulation import Outcome
from .test_entries import TestSpec

MAX_CHUNK = 10  # sensor-noise repetitions per task


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
    """Submits the tasks of the missing traces and books their outcomes.

    When a worker process dies, every task it took down is retried alone,
    one at a time from then on, so only the task that kills its worker fails.
    """

    def __init__(self, pool: Pool, bench: Bench, folder: Folder, status: CampaignStatus, blob: Any,
                 progress: Callable[[CampaignStatus], None] | None):
        self.pool, self.bench, self.folder, self.status, self.blob = pool, bench, folder, status, blob
        self.progress = progress
        self.running: dict[Any, tuple[Task, bool]] = {}  # future -> (task, ran alone)
        self.queue: deque[Task] = deque()
        self.isolate = False
        self.out_dir = str(folder.traces) if pool.writes_files else None

    def submit(self, task: Task) -> None:
        if self.isolate:
            self.queue.append(task)
            return
        self._launch(task)

    def _launch(self, task: Task) -> None:
        future = self.pool.submit(trace_task, self.bench, task.test, task.repetitions, task.record,
                                  bool(task.later), self.out_dir, self.blob)
        self.running[future] = (task, self.isolate)

    def plan(self, tests: Iterable[TestSpec]) -> None:
        """Queue the tasks of every trace not yet present."""
        for test in tests:
            st = self.status.tests[test.name]
            missing = [r for r in range(test.repetitions) if test.trace_name(r) not in st.present]
            if not missing:
                continue
            if test.noise.actuator:
                for r in missing:
                    self.submit(Task(test, [r]))
            else:
                size = min(MAX_CHUNK, max(1, math.ceil(len(missing) / (4 * self.pool.size))))
                self.submit(Task(test, missing[:size], later=missing[size:]))

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
                self.submit(Task(task.test, task.later[i:i + size], record))

    def run(self) -> None:
        while self.running or self.queue:
            if not self.running:
                self._launch(self.queue.popleft())
            for future in self.pool.wait(self.running):
                self.book(future)
            self.folder.write_status(self.status)
            if self.progress is not None:
                self.progress(self.status)
