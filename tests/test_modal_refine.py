"""The modal method's maximum-likelihood refinement of free-decay poles
(identifier/modal/refine.py): its spread is the Cramer-Rao bound, computed
here independently (Fisher information of damped sinusoids in white noise,
by its analytic derivatives), its standard errors cover the truth, and it
refuses what it does not apply to."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.signal import lfilter

from structbench.identifier import modal
from structbench.identifier.io.traces import Channel, Trace
from structbench.identifier.modal import ml_fit, refine

OMEGA = np.array([2.0, 3.1, 5.3])  # rad/s
ZETA = np.array([0.01, 0.02, 0.015])
SHAPES = np.array([[1.0, 0.7, 0.4], [0.6, -0.5, -1.0], [0.3, -1.0, 0.8]])  # (channel, mode)
AMP, PHASE = np.array([1.0, 0.6, 0.4]), np.array([0.3, 1.2, -0.7])
DT, N, NOISE = 0.05, 2000, 0.02  # 100 s: 2 decay times of mode 1


def clean(t: np.ndarray, omega=OMEGA, zeta=ZETA, shapes=SHAPES, amp=AMP, phase=PHASE) -> np.ndarray:
    """Noise-free displacements (n, channels): ``sum_r phi_r A_r e^(-zeta omega t) cos(omega_d t + phase)``."""
    al, wd = zeta * omega, omega * np.sqrt(1 - zeta**2)
    return (amp * np.exp(-np.outer(t, al)) * np.cos(np.outer(t, wd) + phase)) @ shapes.T


def sigma_of(y0: np.ndarray) -> np.ndarray:
    return NOISE * np.sqrt(np.mean(y0**2, axis=0))


def cramer_rao(t: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """Standard deviations (R, 2) of (omega, zeta): the inverse Fisher
    information of ``(alpha_r, omega_d,r)`` and every channel's amplitudes
    ``(a, b)`` of ``e^(-alpha t) (a cos + b sin)`` from the derivatives of
    the signal, transformed to ``omega = |s|``, ``zeta = alpha / omega``."""
    R, C = OMEGA.size, SHAPES.shape[0]
    al, wd = ZETA * OMEGA, OMEGA * np.sqrt(1 - ZETA**2)
    env = np.exp(-np.outer(t, al))
    cs, sn = env * np.cos(np.outer(t, wd)), env * np.sin(np.outer(t, wd))
    a, b = SHAPES * AMP * np.cos(PHASE), -SHAPES * AMP * np.sin(PHASE)
    rows = []
    for c in range(C):
        nonlinear = []
        for r in range(R):
            nonlinear += [-t * (a[c, r] * cs[:, r] + b[c, r] * sn[:, r]),  # d / d alpha_r
                          t * (b[c, r] * cs[:, r] - a[c, r] * sn[:, r])]  # d / d omega_d,r
        linear = np.zeros((t.size, 2 * R * C))
        linear[:, 2 * R * c:2 * R * (c + 1):2], linear[:, 2 * R * c + 1:2 * R * (c + 1):2] = cs, sn
        rows.append(np.column_stack(nonlinear + [linear]) / sigma[c])
    J = np.vstack(rows)
    cov = np.linalg.inv(J.T @ J)[:2 * R, :2 * R]
    out = np.empty((R, 2))
    for r in range(R):
        T = np.array([[al[r], wd[r]], [wd[r] ** 2 / OMEGA[r] ** 2, -al[r] * wd[r] / OMEGA[r] ** 2]]) / OMEGA[r]
        out[r] = np.sqrt(np.diag(T @ cov[2 * r:2 * r + 2, 2 * r:2 * r + 2] @ T.T))
    return out


def trace(y: np.ndarray, excitation: dict | None = None, dt: float = DT) -> Trace:
    """In-memory trace of displacement records ``y`` (channels, n)."""
    channels = {f"displacement_{i + 1}_w": Channel(f"displacement_{i + 1}_w", row, "displacement", "m", i + 1, "w",
                                                   np.full(3, np.nan), NOISE) for i, row in enumerate(y)}
    return Trace(Path("decay.h5"), np.arange(y.shape[1]) * dt, dt, dt, channels, {},
                 {"test": "decay", "repetition": 0, "structure": "synthetic"}, excitation or {})


def noisy(seed: int, n: int = N) -> tuple[np.ndarray, np.ndarray]:
    y0 = clean(np.arange(n) * DT)
    sigma = sigma_of(y0)
    return (y0 + sigma * np.random.default_rng(seed).standard_normal(y0.shape)).T, sigma


def matched(result, what: str = "result") -> np.ndarray:
    """(R, 4) omega, zeta, their standard errors of the modes nearest the true ones."""
    if what == "result":
        w, z, sw, sz = result.omega, result.damping, result.omega_std, result.damping_std
    else:
        s = result.details["ml_refinement"]["ssi"]
        w, z, sw, sz = s["omega"], s["damping"], s["omega_std"], s["damping_std"]
    w = np.asarray(w)
    idx = [int(np.argmin(np.abs(w - o))) for o in OMEGA]
    assert np.allclose(w[idx], OMEGA, rtol=0.01)
    return np.column_stack([w[idx], np.asarray(z)[idx], np.asarray(sw)[idx], np.asarray(sz)[idx]])


def test_refined_spread_is_the_cramer_rao_bound() -> None:
    """50 seeds of a 3-mode, 3-channel free decay with 2 % white noise: the
    refined omega and zeta spread as the bound (pooled RMS error over the
    bound within 15 %, each quantity within its sampling error), their
    standard errors are the bound's and cover the truth; SSI alone spreads
    about twice the bound."""
    t = np.arange(N) * DT
    bound = cramer_rao(t, sigma_of(clean(t)))
    truth = np.column_stack([OMEGA, ZETA])
    fits, ssi = [], []
    for seed in range(50):
        y, _ = noisy(seed)
        result = modal.identify([trace(y, {"kind": "initial"})])
        assert result.details["ml_refinement"]["modes"] == [True, True, True], result.details["ml_refinement"]
        fits.append(matched(result))
        ssi.append(matched(result, "ssi"))
    fits, ssi = np.array(fits), np.array(ssi)
    err = (fits[:, :, :2] - truth) / bound
    assert 0.85 < np.sqrt(np.mean(err**2)) < 1.15, np.sqrt(np.mean(err**2, axis=0))
    ratio = np.std(fits[:, :, :2], axis=0, ddof=1) / bound  # each +-10 % (1 s.e.) over 50 seeds
    assert np.all((ratio > 0.65) & (ratio < 1.4)), ratio
    np.testing.assert_allclose(np.median(fits[:, :, 2:] / bound, axis=0), 1.0, rtol=0.1)
    covered = np.mean(np.abs(fits[:, :, :2] - truth) <= 1.96 * fits[:, :, 2:])
    assert 0.90 <= covered <= 0.98, covered
    assert np.sqrt(np.mean(((ssi[:, :, :2] - truth) / bound) ** 2)) > 1.5  # what the refinement gains


def test_refine_off_is_the_ssi_answer() -> None:
    """``refine=off`` reports SSI's modes unchanged: the values that
    ``refine=auto`` records as ``details.ml_refinement.ssi`` before refining them."""
    y, _ = noisy(7)
    auto = modal.identify([trace(y)])  # no excitation record: a free decay by its decay
    off = modal.identify([trace(y)], refine="off")
    ssi = auto.details["ml_refinement"]["ssi"]
    assert off.omega == ssi["omega"] and off.damping == ssi["damping"]
    assert off.omega_std == ssi["omega_std"] and off.damping_std == ssi["damping_std"]
    assert off.details["ml_refinement"]["applied"] is False and off.details["ml_refinement"]["reason"] == "refine=off"
    assert auto.details["ml_refinement"]["applied"] and auto.omega != off.omega
    assert np.all(np.array(auto.omega_std) < np.array(off.omega_std))
    # the refined modes' shapes: least squares at the refined poles (identifier/modal/free_shapes.py), near SSI's
    a, b = np.array(auto.mode_shapes), np.array(off.mode_shapes)
    assert not np.array_equal(a, b)
    assert np.all(np.sum(a * b, axis=1) ** 2 / (np.sum(a * a, axis=1) * np.sum(b * b, axis=1)) > 0.999)


def test_refused_for_a_random_response_and_without_ssi_errors() -> None:
    """Not a free decay (a stationary response; a trace whose excitation is a
    force): the SSI answer, with the reason. Without SSI errors
    (``uncertainty="off"``) the values are refined all the same, without errors."""
    rng = np.random.default_rng(3)
    n = 20000
    q = np.zeros((n, 2))
    for r, (w, z) in enumerate([(2.0, 0.02), (3.3, 0.02)]):
        mu = np.exp((-z * w + 1j * w * np.sqrt(1 - z**2)) * DT)
        q[:, r] = lfilter([0.0, 1.0], np.poly([mu, mu.conjugate()]).real, rng.standard_normal(n))
    y = q @ SHAPES[:, :2].T
    y = (y + 0.02 * y.std(axis=0) * rng.standard_normal(y.shape)).T
    result = modal.identify([trace(y)])
    assert not result.details["ml_refinement"]["applied"]
    assert "does not decay" in result.details["ml_refinement"]["reason"]
    assert result.omega == modal.identify([trace(y)], refine="off").omega
    decay, _ = noisy(1)
    forced = modal.identify([trace(decay, {"kind": "random"})])  # decays, but a force acts on it
    assert forced.details["ml_refinement"]["reason"] == "decay.h5: excitation 'random' is no free decay"
    assert forced.omega == modal.identify([trace(decay, {"kind": "random"})], refine="off").omega
    full = modal.identify([trace(decay)])
    quick = modal.identify([trace(decay)], uncertainty="off")  # no SSI errors: refined, no errors stated
    assert quick.details["ml_refinement"]["applied"]
    assert np.all(np.isnan(quick.omega_std)) and np.all(np.isfinite(full.omega_std))
    near = matched(full)  # the noise poles the jackknife drops are fitted too: close, not the same
    assert np.all(np.abs(matched(quick)[:, 0] - near[:, 0]) < near[:, 2])


def direct(y: np.ndarray, omega: np.ndarray, zeta: np.ndarray, omega_std: np.ndarray, zeta_std: np.ndarray,
           candidates=(), records=None, traces=None):
    traces = traces or [trace(y, {"kind": "initial"})]
    return refine.refine_poles(traces, records or [y], DT, omega, zeta, omega_std, zeta_std,
                               np.zeros(omega.size, bool), list(candidates), "auto")


def test_refused_per_mode_when_a_pole_moves_too_far_or_the_fit_fails(monkeypatch: pytest.MonkeyPatch) -> None:
    """A pole that would move more than MOVE SSI standard errors keeps SSI's
    value (and is held while the others are fitted); a fit that does not
    converge keeps them all."""
    y, sigma = noisy(2)
    bound = cramer_rao(np.arange(N) * DT, sigma)
    start_w, start_z = OMEGA * (1 + np.array([0.0, 2e-4, 0.0])), ZETA.copy()
    std_w, std_z = 5 * bound[:, 0], 5 * bound[:, 1]
    std_w[1] = 1e-3 * abs(start_w[1] - OMEGA[1])  # SSI's claim on mode 2 is far tighter than its error
    out = direct(y, start_w, start_z, std_w, std_z)
    assert list(out.applied) == [True, False, True], out.details
    assert "moved" in out.details["mode_reasons"][1] and "SSI kept" in out.details["mode_reasons"][1]
    assert out.omega[1] == start_w[1] and "widened" in out.details["mode_reasons"][1]
    widened = np.sqrt(out.omega_std[1] ** 2 - std_w[1] ** 2)  # the move, rad/s: to the truth, within its bound
    assert widened > refine.MOVE * std_w[1] and abs(widened - abs(start_w[1] - OMEGA[1])) < 4 * bound[1, 0]
    assert np.all(np.abs(out.omega[[0, 2]] - OMEGA[[0, 2]]) < 4 * bound[[0, 2], 0])
    monkeypatch.setattr(ml_fit, "MAX_ITERATIONS", 0)
    failed = direct(y, start_w, start_z, std_w, 5 * bound[:, 1])
    assert not failed.applied.any() and failed.details["reason"] == "the fit did not converge"
    assert np.array_equal(failed.omega, start_w)


def test_unreported_mode_is_a_nuisance_term() -> None:
    """A mode SSI did not report (not even as a rejected candidate) is found
    in the residual and fitted as a nuisance term; given as a rejected
    candidate it is taken as one directly. The reported modes stay within
    their errors of the truth."""
    y, sigma = noisy(4)
    bound = cramer_rao(np.arange(N) * DT, sigma)
    keep = [0, 1]
    for candidates in ((), [(OMEGA[2] * 1.001, ZETA[2])]):
        out = direct(y, OMEGA[keep], ZETA[keep], 5 * bound[keep, 0], 5 * bound[keep, 1], candidates)
        assert out.applied.all()
        d = out.details
        assert d["found_in_residual"] == (0 if candidates else 1), d
        assert np.min(np.abs(np.array(d["nuisance"]) - OMEGA[2])) < 0.01 * OMEGA[2]
        assert np.all(np.abs(out.omega - OMEGA[keep]) < 4 * out.omega_std)
        assert np.all(np.abs(out.zeta - ZETA[keep]) < 4 * out.zeta_std)


def test_truncated_to_five_decay_times_and_several_records() -> None:
    """A record much longer than the decay is cut to DECAYS decay times of the
    slowest reported mode; two records of different lengths share the poles."""
    t = np.arange(40000) * DT
    fast = np.array([0.05, 0.06, 0.05])  # the slowest lasts 1 / (0.05 x 2) = 10 s: 50 s used of 2000
    y0 = clean(t, zeta=fast)
    sigma = sigma_of(y0[:2000])
    y = (y0 + sigma * np.random.default_rng(5).standard_normal(y0.shape)).T
    out = direct(y, OMEGA, fast, 0.01 * OMEGA, 0.2 * fast)
    assert out.applied.all() and out.details["samples"] == int(np.ceil(5 / (0.05 * 2.0) / DT))
    second = (clean(t[:700], zeta=fast, phase=PHASE + 1.0) + sigma * np.random.default_rng(6).standard_normal(
        (700, 3))).T
    both = direct(None, OMEGA, fast, 0.01 * OMEGA, 0.2 * fast, records=[y, second],
                  traces=[trace(y, {"kind": "initial"}), trace(second, {"kind": "initial"})])
    assert both.applied.all()
    assert np.all(both.omega_std < out.omega_std)  # more data
    assert np.all(np.abs(both.omega - OMEGA) < 4 * both.omega_std)
