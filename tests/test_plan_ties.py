"""Layouts do not depend on rounding: effective independence below the
number of modes (every ``E_c`` 1), near ties broken by candidate index, and
the same plan twice giving the same layout on a model whose modes come from
a randomly started sparse eigensolver (> 600 DOF)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

import structbench as sb
from structbench.planning import layouts
from structbench.planning import targeted as tg
from test_plan_layout import small_beam


def _psi(folder: Path, elements: int) -> tuple[np.ndarray, list]:
    """``psi`` (C, R) of every displacement DOF of :func:`small_beam`, and the candidates."""
    campaign = sb.load_campaign(small_beam(folder, elements))
    cands = layouts.read_candidates(folder / "cand.toml", campaign.model)
    _, psi, _ = layouts.candidate_information(campaign.model, campaign.tests[0], cands)
    return psi, cands


def test_tied_order() -> None:
    values = np.array([1.0, 1.0 + 1e-9, 0.5, 1.0 - 1e-9, np.inf, 2.0])
    assert tg.tied_order(values, 1e-6).tolist() == [2, 0, 1, 3, 5, 4]  # the near-1 values by position
    assert tg.tied_order(values, 0.0).tolist() == [2, 3, 0, 1, 5, 4]


def test_span_distances_are_gram_determinant_ratios() -> None:
    """``d_c^2 = det(G) / det(G_-c)``, ``G = P P^T`` (Cramer's rule on the
    Gram matrix); a row repeated up to 1e-12 is at distance about 0."""
    P = np.random.default_rng(3).standard_normal((5, 8))
    G = P @ P.T
    ratio = [np.linalg.det(G) / np.linalg.det(np.delete(np.delete(G, c, 0), c, 1)) for c in range(5)]
    np.testing.assert_allclose(layouts._span_distances(P) ** 2, ratio, rtol=1e-10)
    twin = np.vstack([P, P[1] * (1 + 1e-12)])
    d = layouts._span_distances(twin)
    assert d[1] < 1e-9 and d[5] < 1e-9 and d[[0, 2, 3, 4]].min() > 0.1


def test_effective_independence_against_determinants() -> None:
    """Backward elimination by brute-force determinants: above R rows the one
    whose removal keeps the largest ``det(Psi^T Psi)``, then the largest
    ``det(Psi Psi^T)`` (generic random rows: no ties)."""
    psi = np.abs(np.random.default_rng(8).standard_normal((14, 6)))
    keep = list(range(14))
    while len(keep) > 3:
        def volume(rows: list[int]) -> float:
            P = psi[rows]
            return np.linalg.slogdet(P.T @ P if len(rows) >= 6 else P @ P.T)[1]
        keep.remove(max(keep, key=lambda c: volume([r for r in keep if r != c])))
    assert layouts.effective_independence(psi, np.arange(14), 3) == keep


def test_effective_independence_ignores_rounding(tmp_path: Path) -> None:
    """A symmetric beam (24 candidates, 16 modes, mirror-image rows of psi
    proportional): relative perturbations of 1e-10 (the run-to-run
    difference of the 1,000-DOF beam's psi) leave the 4-channel layout as is
    (before the tie rules: 15-19 distinct layouts of 20)."""
    psi, _ = _psi(tmp_path, 12)
    assert psi.shape == (24, 16)
    rng = np.random.default_rng(5)
    base = layouts.effective_independence(psi, np.arange(24), 4)
    for _ in range(20):
        assert layouts.effective_independence(psi * (1 + 1e-10 * rng.standard_normal(psi.shape)),
                                              np.arange(24), 4) == base


def test_same_layout_from_a_random_eigensolver_start(tmp_path: Path) -> None:
    """602 DOF: the modes come from ARPACK, started from a random vector, so
    ``psi`` differs in the last digits between calls; the effective-
    independence layout of 10 channels (below the 22 modes) does not
    (before the tie rules: 4 distinct layouts in 4 calls)."""
    first, cands = _psi(tmp_path, 301)
    second, _ = _psi(tmp_path, 301)
    assert first.shape == (602, 22)
    locations = np.arange(len(cands))
    assert (layouts.effective_independence(first, locations, 10)
            == layouts.effective_independence(second, locations, 10))
