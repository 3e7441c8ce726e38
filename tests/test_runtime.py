"""Process tuning of the modal method (identifier/modal/runtime.py) is
opt-in: measured in fresh processes, an identification leaves glibc's
allocator and the BLAS thread count as it found them unless the process
called ``tune_process()`` or set ``STRUCTBENCH_TUNE_PROCESS=1``."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from structbench.identifier.modal.runtime import ENVIRONMENT, keep_freed_memory

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"
SCRIPT = f"""
import resource, sys
sys.path.insert(0, {str(BENCHMARKS)!r})
import numpy as np
from threadpoolctl import threadpool_info
import modal_fuzz
from modal_synth import free_decays
from structbench.identifier import modal
from structbench.identifier.modal import runtime
if sys.argv[1] == "call":
    runtime.tune_process()
shapes = np.linalg.qr(np.random.default_rng(3).standard_normal((10, 4)))[0]
omega, zeta = np.array([2.1, 5.3, 9.8, 14.2]), np.array([0.002, 0.003, 0.004, 0.002])
y = free_decays(omega, zeta, shapes, np.ones((1, 4), complex), 0.05, 20000, 0.02, 1)[0]
record = modal_fuzz.trace(y, 0.05)
threads = [i["num_threads"] for i in threadpool_info()]
modal.identify([record], uncertainty="off")
modal.identify([record], uncertainty="off")
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
modes = modal.identify([record], uncertainty="off").omega
faults = resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before
print(faults, len(modes), int(threads == [i["num_threads"] for i in threadpool_info()]))
"""


def _run(setting: str) -> tuple[int, int, bool]:
    """Minor page faults of the third identification of one record in a
    fresh process, the number of modes it found, and whether the BLAS
    thread counts after the calls are those before (the first two
    identifications set the heap's high-water mark)."""
    env = {k: v for k, v in os.environ.items() if k != ENVIRONMENT}
    if setting == "environment":
        env[ENVIRONMENT] = "1"
    done = subprocess.run([sys.executable, "-c", SCRIPT, setting], capture_output=True, text=True, check=True,
                          env=env)
    faults, modes, same_threads = done.stdout.split()
    return int(faults), int(modes), same_threads == "1"


@pytest.mark.skipif(not keep_freed_memory(), reason="a C library without glibc's mallopt")
def test_tuning_is_opt_in_and_keeps_freed_memory_when_asked():
    """Four modes on 10 sensors, 20,000 samples. By default glibc keeps its
    thresholds, so every Hankel product's few-MB arrays are faulted in again
    (thousands of pages per identification); opted in by the call or by the
    environment, next to none, and the same modes. The BLAS thread count is
    restored after every call either way."""
    default, modes_default, threads_default = _run("default")
    called, modes_called, threads_called = _run("call")
    environment, modes_environment, threads_environment = _run("environment")
    assert default > 2000
    assert called < default / 20 and environment < default / 20
    assert modes_default == modes_called == modes_environment == 4
    assert threads_default and threads_called and threads_environment
