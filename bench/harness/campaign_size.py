"""What a campaign would write and simulate, checked against its ``[limits]``
test by test as the file is read, so that an absurd campaign (a generated
frequency list gone wrong, a duration in ms written as s) fails at once,
naming the test, instead of running for days or filling the disk.

A trace file holds float64 arrays, uncompressed: the time, one array per
channel and one per commanded force DOF, so ``8 (1 + channels + forces) n``
bytes for ``n`` samples (plus a few kB of attributes).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from structbench.models import Model

from .test_entries import TestSpec
from .toml_lines import Path as KeyPath
from .toml_table import CampaignError, Table

LIMITS = {"trace_bytes": 2e9, "total_bytes": 1e11, "trace_files": 100_000, "model_dofs": 1000}  # [limits] defaults


def trace_size(test: TestSpec) -> int:
    """Bytes of one trace file of ``test`` (its arrays)."""
    return 8 * test.n_samples * (1 + len(test.channels) + len(test.force_dofs))


def human_bytes(n: float) -> str:
    """``n`` bytes as ``"380 MB"``, ``"3.2 GB"`` (SI prefixes)."""
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= scale:
            return f"{n / scale:.3g} {unit}"
    return f"{n:.0f} B"


@dataclass
class CampaignSize:
    """Tests, trace files, their bytes and the FMU communication steps to simulate
    (once per test; per repetition when actuator noise or a per-repetition
    random force changes the input)."""

    tests: int = 0
    trace_files: int = 0
    total_bytes: int = 0
    steps: int = 0

    def add(self, test: TestSpec) -> None:
        self.tests += 1
        self.trace_files += test.repetitions
        self.total_bytes += test.repetitions * trace_size(test)
        simulations = test.repetitions if test.simulates_each_repetition else 1
        self.steps += simulations * (test.n_samples - 1) * test.substeps

    def __str__(self) -> str:
        return (f"{self.tests} tests, {self.trace_files} trace files (about {human_bytes(self.total_bytes)}), "
                f"{self.steps:,} FMU steps")


class Budget:
    """The ``[limits]`` table and the size of the tests read so far."""

    def __init__(self, table: Table):
        table.allow(tuple(LIMITS), "limits")
        self.trace_bytes = table.number("trace_bytes", LIMITS["trace_bytes"], positive=True)
        self.total_bytes = table.number("total_bytes", LIMITS["total_bytes"], positive=True)
        self.trace_files = table.integer("trace_files", LIMITS["trace_files"], low=1)
        self.model_dofs = table.integer("model_dofs", LIMITS["model_dofs"], low=1)
        self.size = CampaignSize()

    def check_model(self, model: Model, error: Callable[[str], CampaignError]) -> None:
        """Fail (``error`` names the ``structure`` key) when the model has more
        free DOF than ``model_dofs``: its truth (every mode) and the FMU's exact
        discretisation (a matrix exponential of order 2 n) take time ~ n^3."""
        if model.n_dof > self.model_dofs:
            raise error(f"{model.name} has {model.n_dof} free DOF, over limits.model_dofs = {self.model_dofs} "
                        "(the truth and the FMU's exact discretisation take time ~ DOF^3: on 2 cores, 30 s "
                        "at 1000 DOF, over 2 min at 2000); raise [limits] model_dofs")

    def add(self, test: TestSpec, entry: KeyPath, error: Callable[[KeyPath, str], CampaignError]) -> None:
        """Count ``test`` (read from the ``[[tests]]`` entry at ``entry``); fail
        there when it crosses a limit."""
        one = trace_size(test)
        if one > self.trace_bytes:
            raise error(entry, f"{test.name}: a trace of {test.n_samples} samples x "
                               f"{one // (8 * test.n_samples)} arrays is {human_bytes(one)}, over "
                               f"limits.trace_bytes = {self.trace_bytes:g} (a trace is assembled in memory); "
                               "record less or raise [limits] trace_bytes")
        self.size.add(test)
        if self.size.trace_files > self.trace_files:
            raise error(entry, f"{test.name}: {self.size.trace_files} trace files so far (tests x repetitions), "
                               f"over limits.trace_files = {self.trace_files}; raise [limits] trace_files")
        if self.size.total_bytes > self.total_bytes:
            raise error(entry, f"{test.name}: {human_bytes(self.size.total_bytes)} of traces so far, over "
                               f"limits.total_bytes = {self.total_bytes:g}; raise [limits] total_bytes")
