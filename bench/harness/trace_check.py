"""Whether a trace file found in a campaign folder is one the campaign would
write, for the files whose checksum ``status.json`` does not record: a
folder from before checksums were recorded, or a file written after the
last status update. Such a file is kept when it passes; one that does not
is simulated again.
"""
from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

from structbench.models.channels import TRACE_FORMAT, Channel

from .fmu_setup import Bench
from .test_entries import TestSpec


def _same(value: object, expected: object) -> bool:
    """An HDF5 attribute equals ``expected`` (a scalar of the same kind, or text)."""
    if isinstance(value, bytes):
        value = value.decode(errors="replace")
    if isinstance(expected, str) or isinstance(value, str):
        return value == expected
    return np.ndim(value) == 0 and bool(value == expected)


def is_trace_of(path: Path, bench: Bench, test: TestSpec, repetition: int) -> bool:
    """``path`` opens as HDF5 and holds repetition ``repetition`` of ``test`` on
    this FMU: the root attributes (format, campaign, test, repetition, seed,
    FMU checksum, dt, step), the time grid ``k dt``, and exactly the test's
    channels and commanded forces, each (n_samples,) float64 and finite."""
    try:
        with h5py.File(path, "r") as f:
            attrs = {"format": TRACE_FORMAT, "campaign": bench.campaign, "test": test.name, "repetition": repetition,
                     "seed": test.seed(repetition), "fmu_sha256": bench.fmu_sha256, "dt": test.dt,
                     "step": test.step}
            if not all(_same(f.attrs.get(key), value) for key, value in attrs.items()):
                return False
            groups = {"channels": [c.name for c in test.channels],
                      "excitation": [Channel("force", *d).name for d in test.force_dofs]}
            if not all(isinstance(f.get(g), h5py.Group) and sorted(f[g]) == sorted(names)
                       for g, names in groups.items()):
                return False
            arrays = [f.get("time")] + [f[g][name] for g, names in groups.items() for name in names]
            if not all(isinstance(a, h5py.Dataset) and a.shape == (test.n_samples,) and a.dtype == np.float64
                       and np.isfinite(a[()]).all() for a in arrays):
                return False
            return bool(np.array_equal(f["time"][()], np.arange(test.n_samples) * test.dt))
    except (OSError, KeyError, RuntimeError, ValueError, TypeError):  # h5py's errors on damaged files
        return False
