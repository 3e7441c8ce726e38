"""Records as a lab mangles them (benchmarks/modal_odd_records.py: filtered,
resampled, offset, quantised, clipped, a dead or doubled channel, scaled far
from unity) through ``modal.identify``: a result with finite positive errors
at frequencies the record can hold, or an ``IdentificationError``; never any
other exception. Three crashes this found are fixed and kept by
tests/test_modal_band_limited.py and tests/test_modal_odd_channels.py; the
long profile (held-out records, every kind) is the benchmark."""
from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from modal_fuzz import unseen_trace
from modal_odd_records import KINDS
from modal_synth import forced

from structbench.identifier import modal
from structbench.identifier.errors import IdentificationError


@st.composite
def mangled(draw: st.DrawFn) -> tuple[np.ndarray, float]:
    """A random response or free decay of 1-3 modes read by 1-4 sensors (1,000-4,000 samples), mangled
    by one or two kinds of :data:`modal_odd_records.KINDS`."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    n, m, k = draw(st.integers(1_000, 4_000)), draw(st.integers(1, 4)), draw(st.integers(1, 3))
    dt = 0.05
    omega = np.sort(rng.uniform(1.0, 0.8 * np.pi / dt, k))
    zeta = rng.uniform(0.005, 0.05, k)
    if draw(st.booleans()):
        force = rng.standard_normal((k, n + 1_000))
        q = np.array([forced(w, z, dt, f)[0][1_000:] for w, z, f in zip(omega, zeta, force)])
    else:
        t = np.arange(n) * dt
        q = np.exp(-zeta[:, None] * omega[:, None] * t) * np.cos(omega[:, None] * t + rng.uniform(0, 6, (k, 1)))
    y = rng.uniform(-1, 1, (m, k)) @ q
    y = y + 0.01 * y.std(axis=1, keepdims=True) * rng.standard_normal(y.shape)
    for kind in draw(st.lists(st.sampled_from(sorted(KINDS)), min_size=1, max_size=2)):
        out = KINDS[kind](y, dt, rng)
        if out:
            y, dt = out[draw(st.integers(0, len(out) - 1))]
    return y, dt


@settings(max_examples=20)
@given(mangled())
def test_a_mangled_record_is_identified_or_refused(record):
    y, dt = record
    m = y.shape[0]
    trace = unseen_trace({"y": y, "dt": dt, "quantities": ["displacement"] * m, "noise": np.zeros(m)})
    try:
        result = modal.identify([trace])
    except IdentificationError:
        return
    omega, std = np.array(result.omega), np.array(result.omega_std + result.damping_std)
    assert np.all(np.isfinite(std) & (std > 0))
    assert np.all((omega > 0) & (omega <= np.pi / dt * 1.001))
