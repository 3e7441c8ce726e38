"""Spatial deflation of stationary records (identifier/modal/deflation.py;
issue 21 item 3, seventeenth round).

The first record is tuning seed 1,002,053 of ``benchmarks/modal_fuzz.py
--kind unseen`` (17 mixed sensors, 22,834 samples, six supported modes): the
first pass reports four of them and misses the weak, broad 15.45 rad/s
mode (``zeta`` 0.080) beside the light 13.73 and 18.49 rad/s ones; the
deflated pass finds it, its 95 % intervals covering the truth and its
least-squares shape on the 17 channels of MAC 0.99+ with the true one
(the short-lag pass off: on by default, it finds the mode first, and all six
are found). The second
are records of two strong light modes alone on 8 sensors: the deflated pass
must add nothing (at most one record of seeds 0-19)."""
from __future__ import annotations

from pathlib import Path

import modal_fuzz
import numpy as np
from modal_synth import forced

from structbench.identifier import modal
from structbench.identifier.io.traces import Channel, Trace
from structbench.identifier.modal import deflation

WEAK, WEAK_ZETA = 15.4530, 0.0804  # rad/s, seed 1,002,053's weak broad mode


def test_deflated_pass_finds_the_weak_broad_mode(monkeypatch):
    rec = modal_fuzz.unseen_record(1_002_053)
    assert abs(rec["omega"][2] - WEAK) < 1e-3 and abs(rec["zeta"][2] - WEAK_ZETA) < 1e-3
    trace = modal_fuzz.unseen_trace(rec)
    result = modal.identify([trace], short_lags="off")
    w, se = np.array(result.omega), np.array(result.omega_std)
    z, sz = np.array(result.damping), np.array(result.damping_std)
    added = np.array(result.details["deflation"]["added"])
    i = int(np.argmin(np.abs(w - rec["omega"][2])))
    assert added[i] and abs(w[i] - rec["omega"][2]) <= 1.96 * se[i] and abs(z[i] - rec["zeta"][2]) <= 1.96 * sz[i]
    assert not added[np.abs(w[:, None] - rec["omega"][[0, 1, 4, 5]]).min(axis=1) < 0.01 * w].any()
    assert np.isnan(result.mode_shapes_std[i]).all() and len(result.mode_shapes[i]) == 17
    lam = -WEAK_ZETA * WEAK + 1j * WEAK * np.sqrt(1 - WEAK_ZETA**2)  # true shape: phi_i lambda^(0, 1, 2) by quantity
    true = rec["shapes"][:, 2] * lam ** np.array([modal_fuzz.QUANTITIES.index(q) for q in rec["quantities"]])
    psi = np.array(result.mode_shapes_complex[i]) @ np.array([1.0, 1j])
    assert abs(np.vdot(psi, true)) ** 2 / (np.vdot(psi, psi).real * np.vdot(true, true).real) > 0.99  # MAC
    both = modal.identify([trace])  # the default: the short-lag pass adds it, the deflated pass the 18.49 one
    k = int(np.argmin(np.abs(np.array(both.omega) - WEAK)))
    assert both.details["short_lags"]["added"][k]
    assert len(modal_fuzz.match(np.array(both.omega), np.array(both.omega_std), rec["omega"])) == 6
    monkeypatch.setattr(deflation, "LEFT", 10**6)  # no deflated pass: the first pass alone misses it
    first = np.array(modal.identify([trace], short_lags="off").omega)
    assert np.abs(first - rec["omega"][2]).min() > 0.01 * WEAK


def _strong_pair(seed: int) -> Trace:
    """8 velocity sensors of two light modes (about 5 and 12 rad/s, zeta 0.5-2 %)
    under white noise, 2 % sensor noise, 3,000 samples."""
    rng = np.random.default_rng(seed)
    omega = np.array([5.0, 12.0]) * rng.uniform(0.9, 1.1, 2)
    zeta = rng.uniform(0.005, 0.02, 2)
    dt, n = float(np.pi / (3 * omega.max())), 3000
    shapes = rng.standard_normal((8, 2))
    lead = int(5 / (zeta * omega).min() / dt)
    v = np.array([forced(w, z, dt, rng.standard_normal(lead + n))[1][lead:] for w, z in zip(omega, zeta)])
    y = shapes @ v
    y += 0.02 * y.std(axis=1, keepdims=True) * rng.standard_normal(y.shape)
    channels = {f"velocity_{i + 1}_w": Channel(f"velocity_{i + 1}_w", row, "velocity", "m/s", i + 1, "w",
                                               np.full(3, np.nan), 0.0) for i, row in enumerate(y)}
    return Trace(Path("pair.h5"), np.arange(n) * dt, dt, dt, channels, {}, {"test": "pair"}, {})


def test_deflated_and_short_lag_passes_add_nothing_to_strong_modes_alone():
    """Seeds 0-19 (the short profile; on seeds 0-49 the deflated pass gave none a mode): at most one
    record gets a mode from either pass (identifier/modal/short_lags.py runs before the deflation)."""
    details = [modal.identify([_strong_pair(seed)]).details for seed in range(20)]
    for key in ("deflation", "short_lags"):
        assert sum(sum(d[key]["added"]) > 0 for d in details) <= 1, key


def test_no_deflated_pass_without_the_replicate_test():
    """Without the jackknife the pass lacks the test that drops noise modes
    (run on these records at 4,000 samples it added a noise mode to 4 of 50)."""
    assert "deflation" not in modal.identify([_strong_pair(20)], uncertainty="off").details
