"""The modal method's stated shape errors of the higher modes of a random
response against Monte Carlo (identifier/modal/uncertainty.py: the
jackknife plus the shapes' scatter over the model orders and, where it
stands out, their out-of-phase part). The record is the damage beam's
(campaigns/cantilever-25.toml, 5 velocity sensors, tip force 1-1500 rad/s,
2 % noise, dt 0.002 s), 60 s, simulated by exact zero-order-hold modal
superposition; the truth is the FE model's undamped shapes (Rayleigh
damping: real modes). benchmarks/modal_shape_coverage.py gives the figures
on 300 s records."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import scipy.linalg as la
from scipy.signal import lfilter

from structbench.identifier import modal
from structbench.identifier.io.traces import Channel, Trace
from structbench.models.toml_model import load_structure

ROOT = Path(__file__).resolve().parents[1]
NODES = (5, 10, 15, 20, 25)
DT = 0.002


def beam_record(seed: int, seconds: float) -> tuple[Trace, np.ndarray, np.ndarray]:
    """The trace, the true omega (n,) rad/s and shapes at the sensors (5, n)."""
    s = load_structure(ROOT / "campaigns" / "cantilever-25.toml")
    md = s.modes()
    zeta = np.einsum("ir,ij,jr->r", md.shapes, s.damping().toarray(), md.shapes) / (2 * md.omega)
    at = md.shapes[[s.dof_index(n, "w") for n in NODES]]
    tip = md.shapes[s.dof_index(25, "w")]
    n = int(round(seconds / DT))
    rng = np.random.default_rng(seed)
    spectrum = np.fft.rfft(rng.standard_normal(n))
    w = 2 * np.pi * np.fft.rfftfreq(n, DT)
    spectrum[(w < 1.0) | (w > 1500.0)] = 0.0
    f = np.fft.irfft(spectrum, n)
    qdot = np.empty((md.omega.size, n))
    for r, (wr, zr) in enumerate(zip(md.omega, zeta)):
        E = la.expm(np.array([[0.0, 1.0, 0.0], [-wr**2, -2 * zr * wr, 1.0], [0.0, 0.0, 0.0]]) * DT)
        Ad, Bd = E[:2, :2], E[:2, 2]
        den = [1.0, -np.trace(Ad), np.linalg.det(Ad)]
        qdot[r] = lfilter([0.0, Bd[1], Ad[1, 0] * Bd[0] - Ad[0, 0] * Bd[1]], den, tip[r] * f)
    y = at @ qdot
    y += 0.02 * np.sqrt(np.mean(y**2, axis=1, keepdims=True)) * rng.standard_normal(y.shape)
    channels = {f"velocity_{k}_w": Channel(f"velocity_{k}_w", row, "velocity", "m/s", k, "w", np.full(3, np.nan),
                                           0.02) for k, row in zip(NODES, y)}
    trace = Trace(Path("ambient.h5"), np.arange(n) * DT, DT, DT, channels, {},
                  {"test": "ambient", "repetition": 0, "structure": "cantilever-25"}, {"kind": "random"})
    return trace, md.omega, at


def standardised(result, omega: np.ndarray, at: np.ndarray) -> dict[int, list[np.ndarray]]:
    """Per true mode found within 3 %: the entries ``(c b - t) / std / sqrt(1 - h)`` of each run
    (``c`` the weighted least-squares scale of the reported shape ``b`` to the truth ``t``)."""
    out: dict[int, list[np.ndarray]] = {}
    w = np.asarray(result.omega)
    for r, wt in enumerate(omega[:10]):
        i = int(np.argmin(np.abs(w - wt)))
        if abs(w[i] - wt) > 0.03 * wt:
            continue
        b, s = np.asarray(result.mode_shapes[i]), np.asarray(result.mode_shapes_std[i])
        t = at[:, r] / at[np.argmax(np.abs(at[:, r])), r]
        c = np.sum(b * t / s**2) / np.sum(b * b / s**2)
        h = (t / s) ** 2 / np.sum((t / s) ** 2)
        out.setdefault(r, []).append((c * b - t) / s / np.sqrt(1 - h))
    return out


def test_higher_modes_shape_errors_cover() -> None:
    """4 records (seeds 141-144, 60 s): the standardised shape errors of
    modes 6-10 (377-1128 rad/s) have an RMS under 1.4 (the jackknife alone
    gave 1.95: modes 8 and 9 at 2.7) and those of all modes over 0.3 (not
    inflated past use); every reported mode states finite errors."""
    pooled: dict[int, list[np.ndarray]] = {}
    for seed in range(141, 145):
        trace, omega, at = beam_record(seed, 60.0)
        result = modal.identify([trace])
        assert np.all(np.isfinite(result.mode_shapes_std))
        for r, z in standardised(result, omega, at).items():
            pooled.setdefault(r, []).extend(z)
    high = np.concatenate([z for r, zs in pooled.items() if r >= 5 for z in zs])
    every = np.concatenate([z for zs in pooled.values() for z in zs])
    assert high.size >= 60
    assert np.sqrt(np.mean(high**2)) < 1.4, np.sqrt(np.mean(high**2))
    assert np.sqrt(np.mean(every**2)) > 0.3, np.sqrt(np.mean(every**2))
