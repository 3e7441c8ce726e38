"""Whether a stationary record's spectrum holds a candidate mode's peak: a
likelihood-ratio test with a known null distribution.

The periodogram of a stationary record of ``n`` samples at ``dt`` s (no
taper; ``T = n dt``), at the lines ``omega_k = 2 pi k / T``, is the
spectrum times independent exponential variables (Whittle). With the
channels scaled to unit RMS and their periodograms summed, ``P_k``, and the
band's lines averaged in blocks of ``b`` lines (at most ``MAX_BLOCKS``
blocks; a block mean of ``b`` exponentials),

    log L(S) = - b sum_k (log S_k + P_k / S_k)

over the blocks of the candidate's band ``|omega - omega_c| <= h``,
``h = min(max(HALF_WIDTHS zeta_c omega_c, LOOSE omega_c, MIN_LINES 2 pi / T), omega_c / 2)``.
Two models of the band's spectrum, non-negative sums of non-negative terms:

    S0 = a_- (1 - x) + a_+ (1 + x) + sum_j sum_q a_jq L(omega; omega_j, zeta_j) (omega / omega_j)^2q
    S1 = S0 + a_c L(omega; omega_c, zeta'),   L = 1 / ((w_0^2 - omega^2)^2 + (2 zeta w_0 omega)^2)

(``x = (omega - omega_c) / h``; ``j``: the other candidates that the band
does not leave unresolved, ``|omega_j - omega_c| > zeta_j omega_j +
zeta_c omega_c``; a linear oscillator's displacement spectrum is ``L`` at
its pole, its velocity's and acceleration's ``L omega^2`` and ``L
omega^4``, ``q`` in ``NEIGHBOUR_QUANTITIES``: a neighbour's skirt, flat
above an acceleration's mode, is not taken for the candidate's peak),
each fitted by
Whittle maximum likelihood (iteratively reweighted non-negative least
squares, ``S1`` started from ``S0``'s fit), and ``LR = 2 (log L1 - log
L0)``, the largest over ``zeta' = zeta_c`` times each of ``ZETA_STEPS``
(SSI's damping of a lightly damped mode can be far off). Without a peak at
``omega_c``, ``LR`` follows ``chi2(1) / 2`` for one amplitude on its
boundary (``a_c >= 0``); summed channels of a band of rank above one give
lines less scattered than one exponential, so the bound holds. A pole SSI
fits to the covariance estimates' own noise has no peak of its own. The
candidate has a peak when

    p = len(ZETA_STEPS) N P(chi2(1) > LR) / 2 < ALPHA,   N = (n / 2) / max(1, zeta_c omega_c T / pi):

``N``, the number of half-power bands the record's lines hold, is the
number of places a pole could have been fitted (Bonferroni over them and
over the damping ratios tried). Several records are cut to the shortest
and their periodograms added (lines of ``chi2`` of more degrees of
freedom: the bound holds). Assumes white sensor noise and a spectrum that
is smooth over the band apart from the modes. Fails (keeps a pole) where
the band holds a peak that is no mode (a harmonic left in the record, a
coloured force); rejects a true mode whose peak in the summed spectrum is
within the scatter of its neighbours' response (a weak mode that SSI
resolves by its shape), which is why :mod:`identifier.modal.peak_pairs`
applies it to shadows, pairs and candidates projected apart only.
"""
from __future__ import annotations

from collections.abc import Callable, Iterator

import numpy as np
from scipy.optimize import nnls
from scipy.stats import chi2 as chi_square

from .runtime import rfft

ALPHA = 0.01  # chance, per record, that a band without a peak passes
HALF_WIDTHS = 10.0  # band half-width in half-power half-widths zeta omega
LOOSE = 0.005  # ... at least this share of omega
MIN_LINES = 32  # ... and this many lines
ZETA_STEPS = (0.5, 1.0, 2.0, 4.0, 8.0)  # damping ratios tried, x SSI's
MAX_BLOCKS = 512  # the band's lines are averaged in at most this many blocks
NEIGHBOUR_QUANTITIES = (0, 1, 2)  # a neighbour's terms in S0: displacement, velocity, acceleration (x omega^2q)


def peak_shape(omega: np.ndarray, w0: float, zeta: float) -> np.ndarray:
    """A linear oscillator's response spectrum ``L`` (module docstring) at ``omega`` (k,) rad/s, up to scale."""
    return 1.0 / ((w0**2 - omega**2) ** 2 + (2.0 * zeta * w0 * omega) ** 2)


def neighbour_terms(omega: np.ndarray, w0: float, zeta: float) -> list[np.ndarray]:
    """A neighbour's columns of ``S0`` (module docstring) at ``omega`` (k,)
    rad/s: ``L (omega / w0)^2q`` at its pole ``w0`` rad/s, damping ratio
    ``zeta``, ``q`` each of ``NEIGHBOUR_QUANTITIES``."""
    shape = peak_shape(omega, w0, zeta)
    return [shape * (omega / w0) ** (2 * q) for q in NEIGHBOUR_QUANTITIES]


def non_negative(A: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, float]:
    """``argmin |A x - b|, x >= 0`` (A (r, c), b (r,)) and the residual norm:
    ``scipy.optimize.nnls``, given 100 c iterations where its default 3 c
    do not converge (nearly collinear columns: two terms at one pole), then
    the least-squares solution clipped at zero."""
    for maxiter in (None, 100 * A.shape[1]):
        try:
            return nnls(A, b, maxiter=maxiter)
        except RuntimeError:  # "Maximum number of iterations reached."
            continue
    x = np.maximum(np.linalg.lstsq(A, b, rcond=None)[0], 0.0)
    return x, float(np.linalg.norm(A @ x - b))


def whittle(P: np.ndarray, X: np.ndarray, lines: int, start: np.ndarray | None = None,
            iterations: int = 30) -> tuple[float, np.ndarray]:
    """Whittle log-likelihood ``-lines sum(log S + P / S)`` of the band's
    line averages ``P`` (b,) (each the mean of ``lines`` periodogram lines)
    at its maximum over ``S = X a``, ``a >= 0`` (X (b, c), non-negative
    columns): iteratively reweighted non-negative least squares (weights
    ``1 / S``), from ``start`` (c,) if given; the best value met and its
    amplitudes (c,). ``S`` is kept above 1e-9 of the mean line."""
    floor = 1e-9 * P.mean()
    scale = np.maximum(X.max(axis=0), 1e-300)
    Xs = X / scale

    def value(a: np.ndarray) -> float:
        S = np.maximum(Xs @ a, floor)
        return float(-lines * np.sum(np.log(S) + P / S))

    a = non_negative(Xs, P)[0] if start is None else start * scale
    best, best_a = value(a), a
    for _ in range(iterations):
        w = 1.0 / np.maximum(Xs @ best_a, floor)
        step = non_negative(Xs * w[:, None], P * w)[0]
        for _ in range(6):  # halved towards the best while it does not improve
            v = value(step)
            if v > best + 1e-10 * abs(best):
                break
            step = 0.5 * (step + best_a)
        else:
            break
        best, best_a = v, step
    return best, best_a / scale


def scaled_transforms(records: list[np.ndarray], taper: np.ndarray | None = None) -> Iterator[np.ndarray]:
    """Per record (m, n_i), the real FFT (m, n // 2 + 1) of its channels cut
    to the shortest record's ``n`` samples, mean removed, scaled to unit RMS
    and, with ``taper`` (n,), multiplied by it."""
    n = min(y.shape[1] for y in records)
    for y in records:
        y = y[:, :n] - y[:, :n].mean(axis=1, keepdims=True)
        rms = y.std(axis=1)
        y = y / np.where(rms > 0, rms, 1.0)[:, None]
        yield rfft(y if taper is None else y * taper, axis=1)


def channel_periodograms(records: list[np.ndarray]) -> np.ndarray:
    """Each channel's periodogram (m, n // 2 + 1): records (m, n_i) cut to
    the shortest, channels scaled to unit RMS, added over the records."""
    return sum(np.abs(Y) ** 2 for Y in scaled_transforms(records))


def summed_periodogram(records: list[np.ndarray]) -> np.ndarray:
    """``P_k`` (n // 2 + 1,) of the module docstring: records (m, n_i) cut to
    the shortest, channels scaled to unit RMS, their periodograms summed
    over channels and records."""
    return channel_periodograms(records).sum(axis=0)


def projected_periodogram(records: list[np.ndarray], weights: np.ndarray) -> np.ndarray:
    """``|w^H Y_k|^2`` (n // 2 + 1,) summed over the records (m, n_i) cut to
    the shortest: ``Y_k`` (m,) the transforms of the channels scaled to unit
    RMS (as :func:`summed_periodogram`), ``w`` = ``weights`` (m,) complex,
    in the scaled channels."""
    return sum(np.abs(weights.conj() @ Y) ** 2 for Y in scaled_transforms(records))


def spectrum(records: list[np.ndarray], dt: float, summed: np.ndarray | None = None
             ) -> tuple[np.ndarray, np.ndarray, float]:
    """The summed periodogram (:func:`summed_periodogram`, unless given as
    ``summed``) of records (m, n_i) sampled at ``dt`` s, its lines ``2 pi k /
    T`` rad/s and ``T = n dt`` s (``n`` the shortest record)."""
    n = min(y.shape[1] for y in records)
    summed = summed_periodogram(records) if summed is None else summed
    return summed, 2.0 * np.pi * np.arange(n // 2 + 1) / (n * dt), n * dt


def half_width(omega: np.ndarray, zeta: np.ndarray, T: float) -> np.ndarray:
    """The band half-width ``h`` rad/s (k,) of the module docstring for
    candidates at ``omega`` (k,) rad/s, damping ``zeta`` (k,), in records of
    ``T`` s."""
    omega, z = np.asarray(omega, float), np.maximum(np.abs(np.asarray(zeta, float)), 1e-6)
    return np.minimum(np.maximum.reduce([HALF_WIDTHS * z * omega, LOOSE * omega,
                                         np.full_like(omega, MIN_LINES * 2.0 * np.pi / T)]), 0.5 * omega)


def band(summed: np.ndarray, lines: np.ndarray, centre: float, half: float
         ) -> tuple[np.ndarray, np.ndarray, int] | None:
    """The line averages ``P`` (b,) and their frequencies (b,) rad/s of the
    band ``|omega - centre| <= half`` of ``summed`` at ``lines`` rad/s, in
    blocks of the returned number of lines (at most ``MAX_BLOCKS`` blocks);
    None when the band holds under 3 lines."""
    inside = np.flatnonzero(np.abs(lines - centre) <= half)
    if inside.size < 3:
        return None
    size = -(-inside.size // MAX_BLOCKS)  # lines averaged per block
    inside = inside[: inside.size // size * size]
    return summed[inside].reshape(-1, size).mean(axis=1), lines[inside].reshape(-1, size).mean(axis=1), size


def places(n: int, zeta: float, omega: float, T: float) -> float:
    """``N`` of the module docstring: the half-power bands of a candidate at
    ``omega`` rad/s, damping ``zeta``, in the ``n // 2`` lines of ``T`` s."""
    return (n / 2) / max(1.0, max(zeta, 1e-6) * omega * T / np.pi)


def peak_lr(records: list[np.ndarray], dt: float, omega: np.ndarray,
            zeta: np.ndarray, which: list[int] | None = None,
            excluded: dict[int, list[int]] | None = None,
            summed: np.ndarray | None = None, wide: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Per candidate (k,): ``LR`` and its p-value bound with the Bonferroni
    factor (module docstring), for candidates at ``omega`` (k,) rad/s,
    damping ``zeta`` (k,), in stationary records
    (m, n_i) sampled at ``dt`` s; only the candidates ``which`` (all when
    None) are tested, the others are their neighbours only (those the band
    resolves, module docstring; never those ``excluded[c]`` lists for
    candidate ``c``). ``summed``: the periodogram (n // 2 + 1,) of the
    records cut to the shortest, :func:`summed_periodogram` when None.
    ``wide`` (k,): the damping ratios at which each tested candidate's band,
    term and Bonferroni factor are taken, ``zeta`` when None; which
    neighbours the band resolves is judged at ``zeta`` all the same (a
    band widened to a candidate's damping interval would leave a narrow
    neighbour out of ``S0`` and count its peak as the candidate's). A
    candidate untested or whose band holds under 3 lines gets ``LR`` 0 and
    p-value 1."""
    omega, zeta = np.asarray(omega, float), np.abs(np.asarray(zeta, float))
    wide = zeta if wide is None else np.abs(np.asarray(wide, float))
    n = min(y.shape[1] for y in records)
    T = n * dt
    lines = 2.0 * np.pi * np.arange(n // 2 + 1) / T
    k = omega.size
    stat, pvalue = np.zeros(k), np.ones(k)
    summed = summed_periodogram(records) if summed is None else summed
    for c in range(k) if which is None else which:
        z = max(wide[c], 1e-6)
        half = float(half_width(omega[c : c + 1], wide[c : c + 1], T)[0])
        lines_in = band(summed, lines, omega[c], half)
        if lines_in is None:
            continue
        P, w, size = lines_in
        x = (w - omega[c]) / half
        far = (excluded or {}).get(c, [])
        others = [term for j in range(k)
                  if j != c and j not in far and abs(omega[j] - omega[c]) > zeta[j] * omega[j] + zeta[c] * omega[c]
                  for term in neighbour_terms(w, omega[j], max(zeta[j], 1e-6))]
        X0 = np.column_stack([1.0 - x, 1.0 + x] + others)
        base, a0 = whittle(P, X0, size)
        best = base
        for step in ZETA_STEPS:
            value, _ = whittle(P, np.column_stack([X0, peak_shape(w, omega[c], z * step)]), size, np.r_[a0, 0.0])
            best = max(best, value)
        stat[c] = 2.0 * (best - base)
        pvalue[c] = min(1.0, 0.5 * chi_square.sf(stat[c], 1) * len(ZETA_STEPS) * places(n, z, omega[c], T))
    return stat, pvalue


def channel_halves(records: list[np.ndarray]) -> tuple[tuple[list[np.ndarray], np.ndarray], ...]:
    """The first and the second half of records (m, n_i) cut to the shortest,
    each with its :func:`channel_periodograms` (m, n // 4 + 1)."""
    n = min(y.shape[1] for y in records)
    parts = ([y[:, : n // 2] for y in records], [y[:, n // 2 : n] for y in records])
    return tuple((part, channel_periodograms(part)) for part in parts)


def in_one_channel(records: list[np.ndarray], pvalue: Callable[[list[np.ndarray], np.ndarray], np.ndarray],
                   halves: tuple[tuple[list[np.ndarray], np.ndarray], ...] | None = None) -> np.ndarray:
    """The chance that one channel shows a peak: ``min(1, m min_i max(p_i',
    p_i''))`` (k,) over the m channels of the records (m, n_i) cut to the
    shortest, ``p_i'`` and ``p_i''`` the p-values (k,) that ``pvalue(part,
    periodogram)`` gives channel i's periodogram in the first and the second
    half of them (``halves``: :func:`channel_halves` of the records, computed
    when None). One channel's periodogram is its spectrum times independent
    exponentials (Whittle), so each half's p-value is valid, the larger of the
    two too; the factor m holds whatever the channels' correlation. A
    stationary mode's peak is in both halves; a transient's (a free decay's
    high mode that dies out early in a record taken for stationary), whose
    shape one channel's cross terms distort where the sum over channels
    averages them out, is not."""
    halves = channel_halves(records) if halves is None else halves
    each = np.array([[pvalue(part, row) for row in rows] for part, rows in halves])  # (2, m, k)
    return np.minimum(1.0, each.shape[1] * each.max(axis=0).min(axis=0))


def peak_in_any(records: list[np.ndarray], dt: float, omega: np.ndarray, zeta: np.ndarray,
                which: list[int]) -> np.ndarray:
    """p-values (k,) of the candidates ``which`` (the others 1; arguments as
    :func:`peak_lr`, every candidate a neighbour) for a peak in the summed
    periodogram or in one channel's: ``min(1, 2 min(p_sum, p_one))``,
    ``p_one`` by :func:`in_one_channel` (``p_sum`` alone for one channel).
    A weak mode that few channels see above their noise (a low-noise
    sensor, or a quantity that favours its band) is diluted in the unit-RMS
    sum by the channels whose noise or other modes fill its band."""
    _, summed = peak_lr(records, dt, omega, zeta, which)
    if records[0].shape[0] == 1:
        return summed
    one = in_one_channel(records, lambda part, row: peak_lr(part, dt, omega, zeta, which, summed=row)[1])
    return np.minimum(1.0, 2.0 * np.minimum(summed, one))
