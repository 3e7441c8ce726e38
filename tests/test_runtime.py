"""Process settings of the identifier (identifier/runtime.py), measured in
fresh processes: whatever earlier tests allocated and freed does not
change what glibc does there."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from structbench.identifier.modal.runtime import keep_freed_memory

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"
SCRIPT = f"""
import resource, sys
sys.path.insert(0, {str(BENCHMARKS)!r})
import numpy as np
import modal_fuzz
from modal_synth import free_decays
from structbench.identifier import modal
if sys.argv[1] == "off":
    modal.keep_freed_memory = lambda: False
shapes = np.linalg.qr(np.random.default_rng(3).standard_normal((10, 4)))[0]
omega, zeta = np.array([2.1, 5.3, 9.8, 14.2]), np.array([0.002, 0.003, 0.004, 0.002])
y = free_decays(omega, zeta, shapes, np.ones((1, 4), complex), 0.05, 20000, 0.02, 1)[0]
record = modal_fuzz.trace(y, 0.05)
modal.identify([record], uncertainty="off")
modal.identify([record], uncertainty="off")
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
modes = modal.identify([record], uncertainty="off").omega
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before, len(modes))
"""


def _faults(setting: str) -> tuple[int, int]:
    """Minor page faults of the third identification of one record in a
    fresh process, and the number of modes it found (the first two set the
    heap's high-water mark: the first also makes the probe's spectrum that
    :func:`identifier.modal.ssi.hankel.leading_svd` keeps, and the second's
    arrays then lie around it)."""
    done = subprocess.run([sys.executable, "-c", SCRIPT, setting], capture_output=True, text=True, check=True)
    faults, modes = done.stdout.split()
    return int(faults), int(modes)


@pytest.mark.skipif(not keep_freed_memory(), reason="a C library without glibc's mallopt")
def test_freed_memory_is_reused_not_faulted_in_again():
    """Four modes on 10 sensors, 20,000 samples: with glibc's default
    thresholds every Hankel product's few-MB arrays are faulted in again
    (3,600-6,700 pages per identification once the heap has settled); with
    the thresholds raised, next to none, and the same modes."""
    default, modes_default = _faults("off")
    kept, modes_kept = _faults("on")
    assert default > 2000  # 4,500-6,700 here
    assert kept < default / 20  # 0-3 here
    assert modes_kept == modes_default == 4
