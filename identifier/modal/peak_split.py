"""Whether a stationary candidate's band holds more than the one mode its
pole models: a likelihood-ratio test on the periodogram of
:mod:`identifier.modal.peak_test`.

SSI of a short or few-sensor random response can fit one pole over two
modes the record resolves: its frequency between theirs, its damping
inflated to span both, its interval reaching neither (tuning seeds
1,006,369 and 1,007,669, docs/modal-method.md, sixteenth round). Over the
candidate's band (``peak_test.half_width``, its lines in ``peak_test.band``'s
blocks), with the background and the other candidates the band resolves
as ``S0`` (as in ``peak_test``), two models are fitted by Whittle maximum
likelihood:

    S_one = S0 + M(omega; w_1, z_1),   S_two = S0 + M(omega; w_1, z_1) + M(omega; w_2, z_2),

``M`` the pair test's oscillator term of three non-negative quantity
amplitudes (:mod:`identifier.modal.peak_pairs`), its pole free within the
band and damping ratios ``Z = [max(zeta_c / 16, pi / (omega_c T)),
4 zeta_c]`` (at least one line of half-power width): started from the
best points of a grid (frequencies ``z omega_c`` apart at each damping
``zeta_c 2^j``, ``j`` in ``STEPS``; grid points ranked by one weighted
least-squares step, :func:`_scan`), then Nelder-Mead on ``(w, log z)``.
``LR = 2 (log L_two - log L_one)``. Under one mode in the band, at a
fixed second pole ``LR`` is a chi-bar-square of the second term's
``Q = 3`` non-negative amplitudes, under ``chi2(3)``; the second pole can
lie in any of the band's half-power cells at any of the damping steps,

    p = C P(chi2(3) > LR),   C = sum_j 2 h / (z_j omega_c)

(Bonferroni over the cells; ``z_j`` the steps' damping ratios, floored as
``Z``). An under-maximised ``L_two`` only lowers ``LR``. The band holds
two modes when ``p < peak_test.ALPHA``, their fitted poles are resolved,

    |w_2 - w_1| > 2 pi / T + z_1 w_1 + z_2 w_2,

and the candidate's 95 % interval reaches neither's half-power band,
``|omega_c - w_i| > max(z_i w_i, pi / T) + 1.96 se_c`` for both (one it
sits on is the mode it models, the other a neighbour SSI missed, no reason
to doubt it): then it is rejected. Assumes white sensor noise and a background smooth over the
band, as ``peak_test``; fails (keeps the pole) where the band is under
``MIN_BLOCKS`` blocks or one of its modes hides under the other's skirt.
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import minimize
from scipy.stats import chi2 as chi_square

from . import peak_test
from .peak_test import whittle

STEPS = (-4, -3, -2, -1, 0, 1, 2)  # damping steps of the grid: zeta_c 2^j
MIN_BLOCKS = 16  # least blocks in the band: two terms' 10 parameters and the background's 2, with room
MAX_GRID = 64  # at most this many grid frequencies per damping step
STARTS = 2  # Nelder-Mead runs from this many of the grid's best points
Q = len(peak_test.NEIGHBOUR_QUANTITIES)  # amplitudes of a term


def terms(w: np.ndarray, poles: list[tuple[float, float]]) -> list[np.ndarray]:
    """The columns ``M`` (module docstring) of oscillator terms at ``poles``
    ((rad/s, zeta), ...) over the block frequencies ``w`` (b,) rad/s."""
    return [t for w0, z0 in poles for t in peak_test.neighbour_terms(w, w0, z0)]


def _scan(P: np.ndarray, X: np.ndarray, weights: np.ndarray, w: np.ndarray,
          grid: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """The grid's poles ranked by one weighted least-squares step of the
    Whittle fit (weights ``1 / S`` (b,) of the model fitted so far) with
    ``X`` (b, c) and one more term: the ``STARTS`` best."""
    scores = []
    for pole in grid:
        A = np.column_stack([X] + terms(w, [pole]))
        A = A / np.maximum(A.max(axis=0), 1e-300)
        scores.append(peak_test.non_negative(A * weights[:, None], P * weights)[1])
    return [grid[i] for i in np.argsort(scores)[:STARTS]]


def _fit(P: np.ndarray, X0: np.ndarray, w: np.ndarray, size: int, starts: list[list[tuple[float, float]]],
         bounds: tuple[float, float, float, float]) -> tuple[float, list[tuple[float, float]]]:
    """Whittle's maximum over the poles of ``S0 + M + ...`` (Nelder-Mead
    on ``(w / u, log z)``, ``u`` the narrowest term's half-width, from each
    of ``starts``; stopped at ``u / 20``, 0.01 in ``log L``; each step's
    Whittle fit started from the previous step's amplitudes), poles within
    ``bounds`` (w_lo, w_hi, z_lo, z_hi): the value and the poles."""
    lo, hi, z_lo, z_hi = bounds
    unit = 0.5 * (lo + hi) * z_lo

    def value(x: np.ndarray) -> float:
        poles = [(x[i] * unit, np.exp(x[i + 1])) for i in range(0, x.size, 2)]
        if any(not (lo <= p <= hi and z_lo <= z <= z_hi) for p, z in poles):
            return np.inf
        got, last[0] = whittle(P, np.column_stack([X0] + terms(w, poles)), size, last[0])
        return -got

    best: tuple[float, list[tuple[float, float]]] = (-np.inf, [])
    for start in starts:
        last: list[np.ndarray | None] = [None]  # the amplitudes of the previous step start the next fit
        x0 = np.array([v for p, z in start for v in (p / unit, np.log(z))])
        step = np.array([v for p, z in start for v in (0.5 * z * p / unit, 0.5)])
        with np.errstate(invalid="ignore"):  # a simplex wholly outside the bounds: inf - inf in its stop test
            out = minimize(value, x0, method="Nelder-Mead",
                           options={"initial_simplex": np.vstack([x0, x0 + np.diag(step)]), "maxfev": 60 * x0.size,
                                    "xatol": 0.05, "fatol": 0.01})
        if -out.fun > best[0]:
            best = (-out.fun, [(out.x[i] * unit, np.exp(out.x[i + 1])) for i in range(0, out.x.size, 2)])
    return best


def split_lr(summed: np.ndarray, lines: np.ndarray, T: float, omega: np.ndarray, zeta: np.ndarray, c: int,
             neighbours: list[int]) -> tuple[float, float, list[tuple[float, float]]] | None:
    """``LR``, its p-value bound and the two fitted poles ((rad/s, zeta),
    by frequency) of the band of candidate ``c`` (module docstring), from
    the summed periodogram ``summed`` at ``lines`` rad/s of records of
    ``T`` s; candidates at ``omega`` (k,) rad/s, damping ``zeta`` (k,);
    ``neighbours``: those in ``S0`` when the band resolves them. None when
    the band holds under ``MIN_BLOCKS`` blocks."""
    z = np.maximum(np.abs(zeta), 1e-6)
    wc, zc = float(omega[c]), float(z[c])
    half = float(peak_test.half_width(omega[c : c + 1], z[c : c + 1], T)[0])
    found = peak_test.band(summed, lines, wc, half)
    if found is None or found[0].size < MIN_BLOCKS:
        return None
    P, w, size = found
    x = (w - wc) / half
    X0 = np.column_stack([1.0 - x, 1.0 + x] + terms(w, [(omega[j], z[j]) for j in neighbours
                                                        if abs(omega[j] - wc) > z[j] * omega[j] + zc * wc]))
    floor = np.pi / (wc * T)
    dampings = np.unique(np.maximum(zc * 2.0 ** np.array(STEPS, float), floor))
    grid = [(f, d) for d in dampings
            for f in np.linspace(wc - half, wc + half, int(min(MAX_GRID, np.ceil(2 * half / (d * wc)) + 1)))]
    bounds = (wc - half, wc + half, dampings[0], dampings[-1])
    floor_line = 1e-9 * P.mean()
    starts = _scan(P, X0, 1.0 / np.maximum(np.convolve(P, np.ones(5) / 5, mode="same"), floor_line), w, grid)
    one, pole1 = _fit(P, X0, w, size, [[p] for p in starts + [(wc, max(zc, floor))]], bounds)
    X1 = np.column_stack([X0] + terms(w, pole1))
    seconds = _scan(P, X1, 1.0 / np.maximum(X1 @ whittle(P, X1, size)[1], floor_line), w, grid)
    two, poles = _fit(P, X0, w, size, [pole1 + [p] for p in seconds], bounds)
    stat = max(0.0, 2.0 * (two - one))
    cells = float(np.sum(2.0 * half / (dampings * wc)))
    return stat, min(1.0, cells * chi_square.sf(stat, Q)), sorted(poles)


def screen(records: list[np.ndarray], dt: float, omega: np.ndarray, zeta: np.ndarray, omega_std: np.ndarray,
           reasons: list[str], summed: np.ndarray | None = None) -> None:
    """Set ``reasons[i]`` of each candidate not yet rejected (empty reason)
    whose band holds two modes (module docstring) apart from it: candidates
    at ``omega`` (k,) rad/s, damping ``zeta`` (k,), standard errors
    ``omega_std`` (k,) rad/s, in stationary records (m, n_i) at ``dt`` s;
    the other candidates not rejected are the neighbours; ``summed``: their
    :func:`identifier.modal.peak_test.summed_periodogram`, computed when None."""
    open_ = [i for i in range(omega.size) if not reasons[i]]
    if not open_:
        return
    summed, lines, T = peak_test.spectrum(records, dt, summed)
    se = np.where(np.isfinite(omega_std), omega_std, 0.0)
    for c in open_:
        out = split_lr(summed, lines, T, omega, zeta, c, [j for j in open_ if j != c])
        if out is None or out[1] >= peak_test.ALPHA:
            continue
        stat, pvalue, ((w1, z1), (w2, z2)) = out
        resolved = w2 - w1 > 2 * np.pi / T + z1 * w1 + z2 * w2
        on = any(abs(omega[c] - wi) <= max(zi * wi, np.pi / T) + 1.96 * se[c] for wi, zi in ((w1, z1), (w2, z2)))
        if resolved and not on:
            reasons[c] = (f"its band holds two modes, at {w1:.4g} and {w2:.4g} rad/s (likelihood ratio "
                          f"{stat:.3g}, p-value {pvalue:.2g}; needs under {peak_test.ALPHA:g} for two)")
