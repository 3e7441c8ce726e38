"""Standard errors of the modal method's mode shapes (``mode_shapes_std``)
against Monte Carlo: free decays (least-squares shapes at the refined
poles, identifier/modal/free_shapes.py) and a stationary random response
(the delete-one-group jackknife, identifier/modal/uncertainty.py). The
statistic is the one model updating forms: the reported shape scaled to
the true one by weighted least squares, ``chi^2 = min_c sum_l (c b_l -
t_l)^2 / std_l^2``, which is ``chi^2(m - 1)`` when the stated errors are
right."""
from __future__ import annotations

import numpy as np
from scipy.signal import lfilter
from scipy.stats import chi2

from structbench.identifier import modal
from structbench.identifier.modal.free_shapes import free_decay_shapes
from structbench.identifier.modal.ssi.poles import real_shapes
from structbench.identifier.updating.data import from_run

from test_modal_refine import DT, N, OMEGA, SHAPES, ZETA, clean, noisy, trace


def profiled(b: np.ndarray, t: np.ndarray, std: np.ndarray) -> np.ndarray:
    """Per entry ``(c b - t) / std`` with ``c`` the weighted least-squares scale of ``b`` to ``t``."""
    w = 1.0 / std**2
    c = np.sum(w * b * t) / np.sum(w * b * b)
    return (c * b - t) / std


def truth_normalised() -> np.ndarray:
    return SHAPES / SHAPES[np.argmax(np.abs(SHAPES), axis=0), np.arange(SHAPES.shape[1])]


def statistics(results: list, every: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """chi^2 (runs, modes) and the standardised profiled errors (runs, m,
    modes); ``every`` False: the modes found (within 2 %) only, flat."""
    true = truth_normalised()
    stats, z = [], []
    for result in results:
        w = np.asarray(result.omega)
        idx = [int(np.argmin(np.abs(w - o))) for o in OMEGA]
        if not every:
            for r, i in enumerate(idx):
                if abs(w[i] - OMEGA[r]) < 0.02 * OMEGA[r]:
                    b, std = np.array(result.mode_shapes[i]), np.array(result.mode_shapes_std[i])
                    stats.append(np.sum(profiled(b, true[:, r], std) ** 2))
            continue
        assert np.allclose(w[idx], OMEGA, rtol=0.02)
        b = np.array(result.mode_shapes).T[:, idx]
        std = np.array(result.mode_shapes_std).T[:, idx]
        assert np.all(np.isfinite(std) & (std > 0))
        d = np.column_stack([profiled(b[:, r], true[:, r], std[:, r]) for r in range(OMEGA.size)])
        stats.append(np.sum(d**2, axis=0))
        z.append(d)
    return np.array(stats), np.array(z)


def leverage(t: np.ndarray, std: np.ndarray) -> np.ndarray:
    """``h_l = w_l t_l^2 / sum w t^2``: ``E z_l^2 = 1 - h_l`` for the profiled errors."""
    w = t**2 / std**2
    return w / w.sum()


def test_least_squares_shapes_at_the_poles_cover() -> None:
    """300 seeds of a 3-mode free decay at 3 sensors with 2 % noise, one
    record and two records of different initial conditions, shapes at the
    true poles (identifier/modal/free_shapes.py): the profiled chi^2 has
    its expectation ``m - 1 = 2`` (mean within 10 %, about 2.5 of its
    standard errors) and each entry's standardised error its variance ``1 -
    h_l`` (within 20 %)."""
    t = np.arange(N) * DT
    true = truth_normalised()
    second = clean(t, amp=np.array([0.3, 1.0, 0.8]), phase=np.array([-1.0, 0.4, 2.0]))
    second_sigma = 0.02 * np.sqrt(np.mean(second**2, axis=0))
    for records in (1, 2):
        stats, z2 = [], []
        for seed in range(300):
            y, _ = noisy(seed)
            rng = np.random.default_rng(10_000 + seed)
            ys = [y] if records == 1 else [y, (second + second_sigma * rng.standard_normal(second.shape)).T]
            shapes, std = free_decay_shapes([trace(v, {"kind": "initial"}) for v in ys], ys, DT, OMEGA, ZETA,
                                            np.ones(3, bool), np.zeros((3, 3), complex), np.zeros((3, 3)))
            b = real_shapes(shapes)
            d = np.column_stack([profiled(b[:, r], true[:, r], std[:, r]) for r in range(3)])
            stats.append(np.sum(d**2, axis=0))
            z2.append(d**2 / (1 - np.column_stack([leverage(true[:, r], std[:, r]) for r in range(3)])))
        assert 0.9 < np.mean(stats) / 2 < 1.1, (records, np.mean(stats, axis=0))
        spread = np.sqrt(np.mean(z2, axis=0))
        assert np.all((spread > 0.8) & (spread < 1.2)), (records, spread)


def test_free_decay_shape_errors_end_to_end() -> None:
    """12 seeds through the modal method (refined poles, then the shapes):
    every refined mode states finite shape errors and the profiled chi^2
    mean (36 mode-runs) is within its sampling range of ``m - 1``."""
    results = []
    for seed in range(100, 112):
        y, _ = noisy(seed)
        results.append(modal.identify([trace(y, {"kind": "initial"})]))
        assert results[-1].details["ml_refinement"]["modes"] == [True, True, True]
    stats, _ = statistics(results)
    assert 0.6 < stats.mean() / 2 < 1.5, stats.mean(axis=0)


def random_response(seed: int, n: int = 20000, dt: float = 0.05) -> np.ndarray:
    """Displacements (3, n) of the three modes driven by white noise (modal
    coordinates by a second-order filter each), 2 % white sensor noise."""
    rng = np.random.default_rng(seed)
    q = []
    for w in OMEGA:
        r, th = np.exp(-0.02 * w * dt), w * np.sqrt(1 - 0.02**2) * dt
        q.append(lfilter([1.0], [1.0, -2 * r * np.cos(th), r**2], rng.standard_normal(n)) / w**1.5)
    y = SHAPES @ np.array(q)
    return y + 0.02 * np.sqrt(np.mean(y**2, axis=1, keepdims=True)) * rng.standard_normal(y.shape)


def test_stationary_shape_errors_from_the_jackknife() -> None:
    """8 seeds of a stationary random response (1000 s), the modes found
    (about 20 mode-runs): the jackknife's shape errors give a profiled
    chi^2 whose median is within a factor 3 of chi^2(2)'s (stated errors
    within about 1.7 times the spread; the jackknife of 8 groups is itself
    a rough estimate, and benchmarks on the 25-element beam give its
    figures: docs/results-format.md), and updating reads them."""
    results = [modal.identify([trace(random_response(seed), dt=0.05)], refine="off") for seed in range(200, 208)]
    stats, _ = statistics(results, every=False)
    assert stats.size >= 16
    assert 1 / 3 < np.median(stats) / chi2.median(2) < 3, np.sort(stats)
    data = from_run(results[0].to_dict())
    assert np.all(np.isfinite(data.shape_std)) and data.shape_std.shape == (3, len(results[0].omega))
