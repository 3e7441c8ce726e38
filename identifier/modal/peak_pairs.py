"""Which candidate modes of a stationary record hold a spectral peak of
their own (:mod:`identifier.modal.support`): the pair test, the projected
test and the shadow test, by Whittle likelihood ratios on the periodogram
of :mod:`identifier.modal.peak_test`.

Pairs: two candidates ``a``, ``b`` of alike shapes (:func:`alike`) within
``PAIR_WIDTHS`` half-power half-widths of the broader,

    |omega_a - omega_b| <= PAIR_WIDTHS max(zeta_a omega_a, zeta_b omega_b),

may be one broad mode that SSI fits with two poles. Over the band
``|omega - (omega_a + omega_b) / 2| <= max(h_a, h_b) + |omega_a - omega_b| / 2``
(``h``: :func:`identifier.modal.peak_test.half_width`), with the
background and the neighbours that both resolve (as in ``peak_test``),
two models are fitted by Whittle maximum likelihood:

    S1 = S0 + M(omega; omega_a, s_a zeta_a) + M(omega; omega_b, s_b zeta_b)
    S_one = S0 + M(omega; omega_f, zeta_f),
    M(omega; w, z) = L(omega; w, z) sum_q c_q (omega / w)^2q,  c_q >= 0,

one oscillator term ``M`` per mode holding its response as displacement,
velocity or acceleration (``q`` in ``peak_test.NEIGHBOUR_QUANTITIES``,
as the neighbours' terms): in unit-RMS channels of several quantities a
broad mode's summed periodogram is skewed against ``L`` by ``omega^4``
over its band, and with ``L`` alone two poles fitted the skew better than
one (tuning seed 1,001,169: a mode at 28.70 rad/s, ``zeta`` 0.037, on
ten sensors of three quantities, reported as 28.22 and 29.11 rad/s,
``LR`` 24; with ``M`` 5).
``S1`` at the best damping steps ``s_a, s_b`` of ``peak_test.ZETA_STEPS``,
``S_one`` at the best ``(omega_f, zeta_f)`` over a grid: ``FREE_STEPS``
frequencies over ``[min(omega_a, omega_b) - d, max(omega_a, omega_b) +
d]`` (``d`` the broader's ``zeta omega``) and ``omega_a``, ``omega_b``
themselves, each at the damping ratios ``zeta_a`` and ``zeta_b`` times
each step. ``LR = 2 (log L1 - log L_one)``. The record needs two oscillator
terms when

    p = len(ZETA_STEPS)^2 2 PAIR_WIDTHS P(chi2(Q) > LR) < peak_test.ALPHA

(``Q`` the terms of ``M``; Bonferroni over the damping steps of both terms and over the ``2
PAIR_WIDTHS`` half-widths of the window in which the second pole of one
mode lies: the pair's places are given by SSI, unlike the single test's
noise pole, which could lie in any of the record's bands); the
free fit holds ``S1``'s fit with one of its terms removed, so that under
one mode ``LR`` is at most the statistic of the other term's ``Q``
non-negative amplitudes, a chi-bar-square law whose tail is under
``chi2(Q)``'s: the
level stays ``ALPHA``. Otherwise the candidate whose pole ``s = -zeta
omega + i omega sqrt(1 - zeta^2)`` lies nearer the free fit's is kept
and the other is rejected (comparing the two terms' likelihoods instead
fails both ways: with the damping stepped, a narrow pole beside a broad
mode fits it as well as the mode's own pole, and at their own damping a
narrow term fits the band's random scatter). Pairs are taken
closest first (in half-widths); a candidate already rejected leaves its
pairs.

Apart (projected test): a candidate ``c`` with a better supported one of
another shape (:func:`alike` at most ``PAIR_MAC``) inside its band
(``h_c``) and within ``REACH`` standard errors, ``|omega_j - omega_c| <=
REACH sqrt(se_c^2 + se_j^2)`` (a second, distorted estimate of the
neighbour's frequency), is tested on the periodogram of the channels
(scaled to unit RMS, ``Y_k`` (m,)) projected on its shape apart from the
shapes ``V`` of every candidate of another shape in its band:

    P_k = |w^H Y_k|^2,   w = (I - V V^+) u_c / |(I - V V^+) u_c|

(``u_c`` its unit shape in the scaled channels): one channel's
periodogram, the spectrum times one exponential per line, so that
:func:`identifier.modal.peak_test.peak_lr`'s null law and level hold. The
neighbours' response is removed but for their shapes' errors (their
oscillator terms stay in ``S0``), while the candidate's own mode keeps its
peak. Skipped when ``|(I - V V^+) u_c| < APART`` (the shapes do not tell
them apart).

Shadows (last, :func:`shadows`): a candidate of the shape of a better
supported one (MAC of the complex shapes over ``SHADOW_MAC``), the better
supported one too where its damping is told from zero (``|zeta| >=
1.96 zeta_std``), and each of two alike candidates (:func:`alike` over
``PAIR_MAC``) within the wider of their bands ``h`` whichever is better
supported (SSI can fit a pole of a mode's shape beside it, better
supported than the mode itself: tuning seed 400043's at 30.3 rad/s, 6
half-widths from the true 28.5, and 900897's at 48.5 rad/s on one
sensor, 5 half-widths above the true 37.9, on the flank of its
acceleration spectrum), is tested by
:func:`identifier.modal.peak_test.peak_lr` on the summed periodogram, the
rejected partners of pairs not among its neighbours. The test is at SSI's
damping, so a better supported candidate whose damping the record does
not tell from zero is left to the weak-candidate test below, which tries
the upper end of its damping interval too (tuning seeds 900714 and
900753: true modes of one sensor at 95.7 and 65.0 rad/s, SSI's damping
0.0013 and 0.0018 for the true 0.008 and 0.016, without a peak at SSI's
damping).

Weak candidates (last, :func:`_faint`; :mod:`identifier.modal.support`
names them: damping within 1.96 standard errors of zero, or temporal
coherence under ``support.COHERENT``; ``zeta_top = |zeta| + 1.96 zeta_std``,
the upper end of the damping interval) need a
peak of their own in the summed periodogram, in the channels projected
on their own unit shape (``|u_c^H Y_k|^2``, which shows a weak mode the
summed periodogram hides under other shapes' response) or in one
channel's periodogram in both halves of the record at ``m`` times the
larger p-value (a mode that one low-noise sensor sees, which the other
channels' noise buries in the sum and, weighted by its shape, in the
projection; :func:`identifier.modal.peak_test.in_one_channel`), each by
:func:`identifier.modal.peak_test.peak_lr` at SSI's damping and at
``zeta_top`` (whose band, ``10 zeta_top omega`` wide, holds the peak of a
true mode whose damping SSI underestimates, which the band at SSI's
damping would miss), the smaller p-value of the two times 2: a noise
pole is kept with probability at most ``2 peak_test.ALPHA``; above every
other open candidate at most ``2 TOP_ALPHA``: there the record holds the
background alone (sensor noise, and in an acceleration channel the
random force itself, flat), where SSI's noise poles gather (the Sixth,
Thirteenth and Eighteenth rounds' invented modes, docs/modal-method.md:
500,009, 500,162, 1,001,403, 1,001,767, 1,011,459, 1,012,927), and no
other mode's response hides a true mode's peak there. At
``zeta_top`` the neighbours in ``S0`` are those SSI's damping resolves
(``peak_test.peak_lr``'s ``wide``): the widened band would otherwise
leave a narrow neighbour out and count its peak as the candidate's
(tuning seed 900959: LR 182 at 39.3 rad/s from the true 36.8's peak). The
projected chance is not given to a candidate whose unit shape lies
within the span of the other-shaped candidates in its band (``zeta_top``'s;
part apart under ``APART``, as the projected test): its shape is a mix
of theirs, so the channels projected on it show their peaks (900959's
39.3: 0.15 apart, LR 36 in its shape from its neighbour's skirts).

Shapes are compared (``SHADOW_MAC``, :func:`alike`) in unit-RMS channels
(:func:`unit_scaled`, the channels of the periodograms): in physical units
one channel of a large quantity (an acceleration beside displacements)
makes unlike shapes score MAC 0.95-1.

Fails (drops a true mode) where two true modes of alike shapes lie within
``PAIR_WIDTHS`` half-widths and the record does not hold enough of them
to need two terms in the summed periodogram, or where a weak true mode
beside a strong one holds too little of the projected periodogram to
pass the single test's Bonferroni factor, or where an alike true mode in
another's band holds too little of the summed periodogram; keeps a
spurious pole whose neighbour is no better supported or over ``REACH``
standard errors away, or of a shape over ``PAIR_MAC`` but under
``SHADOW_MAC`` outside the bands of its alike neighbours (tuning seed
400123's unit-RMS MAC 0.90 of 49 channels, noisy ones weighing as much as
clean ones).
"""
from __future__ import annotations

import numpy as np
from scipy.stats import chi2 as chi_square

from structbench.models.mac import mac

from . import peak_test
from .peak_test import ZETA_STEPS, whittle
from .ssi.poles import real_shapes

SHADOW_MAC = 0.95  # a mode this alike (MAC) to a better supported one must show a spectral peak
PAIR_MAC = 0.8  # two modes this alike (MAC of complex or real shapes) ...
PAIR_WIDTHS = 3.0  # ... within this many half-power half-widths zeta omega of the broader: the pair test
FREE_STEPS = 13  # frequencies of the one-oscillator fit's grid
REACH = 4.0  # ... within this many standard errors of the candidate's frequency
APART = 0.3  # least norm of a unit shape's part apart from its neighbours' shapes for the projected test
TOP_ALPHA = 0.001  # the weak-candidate test's level above every other candidate (module docstring)


def alike(shapes: np.ndarray) -> np.ndarray:
    """(k, k): the larger of the MAC of the complex ``shapes`` (m, k) and of
    their real forms (:func:`identifier.modal.ssi.poles.real_shapes`; with
    sensors of several quantities a shape's entries differ in phase by
    quantity, and the complex MAC of two estimates of one mode can be low)."""
    if shapes.shape[1] < 2:
        return np.zeros((shapes.shape[1],) * 2)
    return np.maximum(mac(shapes, shapes), mac(real_shapes(shapes), real_shapes(shapes)))


def pairs(omega: np.ndarray, zeta: np.ndarray, shapes: np.ndarray, open_: list[int]) -> list[tuple[int, int]]:
    """The pairs ``(a, b)``, ``a < b``, of candidates of ``open_`` that the
    pair test takes (module docstring), closest first in half-widths:
    candidates at ``omega`` (k,) rad/s, damping ``zeta`` (k,), complex
    ``shapes`` (m, k)."""
    width = np.abs(zeta) * omega
    like = alike(shapes)
    found = [(abs(omega[a] - omega[b]) / max(width[a], width[b], 1e-300), a, b)
             for a in open_ for b in open_ if a < b and like[a, b] > PAIR_MAC]
    return [(a, b) for gap, a, b in sorted(found) if gap <= PAIR_WIDTHS]


def pair_lr(summed: np.ndarray, lines: np.ndarray, T: float, omega: np.ndarray, zeta: np.ndarray,
            a: int, b: int, excluded: set[int]) -> tuple[float, float, int]:
    """``LR``, its p-value bound and the candidate (``a`` or ``b``) that one
    oscillator term prefers (module docstring), from the summed periodogram
    ``summed`` at ``lines`` rad/s of records of ``T`` s; candidates
    at ``omega`` (k,) rad/s, damping ``zeta`` (k,); the candidates
    ``excluded`` are no neighbours. A band of under 3 lines: ``LR`` 0,
    p-value 1, ``a``."""
    z = np.maximum(np.abs(zeta), 1e-6)
    centre, gap = 0.5 * (omega[a] + omega[b]), abs(omega[a] - omega[b])
    half = min(float(peak_test.half_width(omega[[a, b]], z[[a, b]], T).max()) + 0.5 * gap, 0.5 * centre)
    lines_in = peak_test.band(summed, lines, centre, half)
    if lines_in is None:
        return 0.0, 1.0, a
    P, w, size = lines_in
    x = (w - centre) / half
    others = [term for j in range(omega.size)
              if j not in (a, b) and j not in excluded
              and all(abs(omega[j] - omega[c]) > z[j] * omega[j] + z[c] * omega[c] for c in (a, b))
              for term in peak_test.neighbour_terms(w, omega[j], z[j])]
    X0 = np.column_stack([1.0 - x, 1.0 + x] + others)
    _, a0 = whittle(P, X0, size)

    def fit(*terms: tuple[float, float]) -> float:
        X = np.column_stack([X0] + [t for w0, z0 in terms for t in peak_test.neighbour_terms(w, w0, z0)])
        return whittle(P, X, size, np.r_[a0, np.zeros(X.shape[1] - X0.shape[1])])[0]

    two = max(fit((omega[a], z[a] * sa), (omega[b], z[b] * sb)) for sa in ZETA_STEPS for sb in ZETA_STEPS)
    dampings = np.r_[z[a] * np.array(ZETA_STEPS), z[b] * np.array(ZETA_STEPS)]
    spread = max(z[a] * omega[a], z[b] * omega[b])
    grid = np.r_[omega[a], omega[b],
                 np.linspace(min(omega[a], omega[b]) - spread, max(omega[a], omega[b]) + spread, FREE_STEPS)]
    trials = [(fit((w0, zz)), w0, zz) for w0 in grid if w0 > 0 for zz in dampings]
    one, w_f, z_f = max(trials)
    stat = max(0.0, 2.0 * (two - one))
    looks = len(ZETA_STEPS) ** 2 * 2.0 * PAIR_WIDTHS  # the Bonferroni factor
    pvalue = min(1.0, chi_square.sf(stat, len(peak_test.NEIGHBOUR_QUANTITIES)) * looks)
    pole = (lambda w0, z0: complex(-z0 * w0, w0 * np.sqrt(max(1.0 - z0 * z0, 0.0))))  # s rad/s
    near = [abs(pole(omega[c], z[c]) - pole(w_f, z_f)) for c in (a, b)]
    return stat, pvalue, a if near[0] <= near[1] else b


def screen(records: list[np.ndarray], dt: float, omega: np.ndarray, zeta: np.ndarray, omega_std: np.ndarray,
           support: np.ndarray, scaled: np.ndarray, reasons: list[str], weak: np.ndarray, why: list[str],
           settled: np.ndarray, summed: np.ndarray | None = None) -> None:
    """Set ``reasons[i]`` of each candidate ``i`` not yet rejected (empty
    reason) that the pair test, the projected test or the shadow test
    rejects (module docstring; the shadow test: a candidate :func:`shadows`
    flags needs a peak of its own, :func:`identifier.modal.peak_test.peak_lr`): candidates at ``omega``
    (k,) rad/s, damping ``zeta`` (k,), ``support`` (k,) stable poles,
    complex shapes ``scaled`` (m, k) in unit-RMS channels
    (:func:`unit_scaled`), in stationary records (m, n_i) at ``dt`` s;
    ``weak`` (k,): for each candidate that needs a peak too (:func:`_faint`)
    the upper end of its damping interval, NaN for the others; ``why``
    (k,): the reason it needs one, which its rejection names; ``settled``
    (k,) bool: damping told from zero (:func:`shadows`); ``summed``: the
    records' :func:`identifier.modal.peak_test.summed_periodogram`, computed when None."""
    k = omega.size
    if k == 0:
        return
    open_ = [i for i in range(k) if not reasons[i]]
    dropped: set[int] = set()
    n = min(y.shape[1] for y in records)
    summed = peak_test.summed_periodogram(records) if summed is None else summed  # every test below reads it
    found = pairs(omega, zeta, scaled, open_) if k > 1 else []
    if found:
        T = n * dt
        lines = 2.0 * np.pi * np.arange(n // 2 + 1) / T
        for a, b in found:
            if a in dropped or b in dropped:
                continue
            stat, pvalue, keep = pair_lr(summed, lines, T, omega, zeta, a, b, dropped)
            if pvalue >= peak_test.ALPHA:
                lose = b if keep == a else a
                dropped.add(lose)
                reasons[lose] = (f"one mode with the mode at {omega[keep]:.6g} rad/s: one oscillator term "
                                 f"explains their band (likelihood ratio of two terms {stat:.3g}, p-value "
                                 f"{pvalue:.2g}; needs under {peak_test.ALPHA:g})")
    _apart(records, dt, omega, zeta, omega_std, support, scaled, reasons, open_, dropped)
    open_ = [i for i in open_ if not reasons[i]]
    shadowed = shadows(omega, zeta, np.asarray(support), scaled, n * dt, settled)
    shadowed[:, sorted(dropped)] = False  # a rejected partner shadows nothing
    doubted = [i for i in open_ if i not in dropped and shadowed[i].any()]
    if doubted:
        stat, pvalue = peak_test.peak_lr(records, dt, omega, zeta, doubted,
                                         excluded={i: sorted(dropped) for i in doubted}, summed=summed)
        for i in doubted:
            if pvalue[i] >= peak_test.ALPHA:
                reasons[i] = (f"no spectral peak of its own (likelihood ratio {stat[i]:.3g}, p-value "
                              f"{pvalue[i]:.2g} over the record's bands; needs under {peak_test.ALPHA:g})")
    _faint(records, dt, summed, omega, zeta, weak, scaled, reasons,
           [i for i in open_ if not reasons[i] and np.isfinite(weak[i])], sorted(dropped), why)


def _faint(records: list[np.ndarray], dt: float, summed: np.ndarray, omega: np.ndarray, zeta: np.ndarray,
           top: np.ndarray, scaled: np.ndarray, reasons: list[str], faint: list[int], dropped: list[int],
           why: list[str]) -> None:
    """The weak-candidate test (module docstring): each candidate of
    ``faint`` needs a peak of its own in the summed periodogram, in the
    channels projected on its own shape or in one channel's periodogram in
    both halves of the records (:func:`identifier.modal.peak_test.in_one_channel`; ``summed``: the records' summed
    periodogram, :func:`identifier.modal.peak_test.summed_periodogram`;
    ``scaled`` (m, k), unit-RMS channels), tested at SSI's damping ``zeta`` and at ``top`` (k,), the
    upper end of its damping interval (p-value the smaller of the two
    times 2; the neighbours resolved at ``zeta``), the projected and the
    channels' chances only for a shape ``APART`` from the other-shaped candidates in its
    band; ``dropped`` candidates not among its neighbours; ``why`` (k,)
    the reason each needs a peak. Level ``TOP_ALPHA`` for a candidate above
    every other open one, ``peak_test.ALPHA`` elsewhere."""
    if not faint:
        return
    like = alike(scaled)
    half = peak_test.half_width(omega, top, min(y.shape[1] for y in records) * dt)  # at zeta_top
    open_ = [j for j in range(omega.size) if not reasons[j]]
    halves = None  # the records' halves and their channels' periodograms, once a candidate needs them
    for i in faint:
        level = TOP_ALPHA if omega[i] > max((omega[j] for j in open_ if j != i), default=0.0) else peak_test.ALPHA
        high = np.where(np.arange(omega.size) == i, top, zeta)

        def test(spectrum: np.ndarray, part: list[np.ndarray]) -> tuple[float, float]:
            found = [peak_test.peak_lr(part, dt, omega, zeta, [i], excluded={i: dropped}, summed=spectrum,
                                       wide=z) for z in (zeta, high)]
            return max(stat[i] for stat, _ in found), min(1.0, 2.0 * min(p[i] for _, p in found))

        stat, pvalue = test(summed, records)
        if pvalue < level:
            continue
        u = scaled[:, i] / max(np.linalg.norm(scaled[:, i]), 1e-300)
        others = [j for j in range(omega.size) if j != i and j not in dropped and like[i, j] <= PAIR_MAC
                  and abs(omega[j] - omega[i]) <= half[i]]
        apart = np.linalg.norm(u - scaled[:, others] @ np.linalg.lstsq(scaled[:, others], u, rcond=None)[0]) \
            if others else 1.0
        if apart < APART:
            reasons[i] = (f"{why[i]}, no spectral peak of its own at zeta {abs(zeta[i]):.3g} or "
                          f"{top[i]:.3g} (likelihood ratio {stat:.3g}, p-value {pvalue:.2g}; needs under "
                          f"{level:g}) and a shape {apart:.2f} apart from its neighbours' (under {APART:g})")
            continue
        own, p_own = test(peak_test.projected_periodogram(records, u), records)
        if p_own < level:
            continue
        p_one = 1.0
        if len(scaled) > 1:
            halves = peak_test.channel_halves(records) if halves is None else halves
            p_one = float(peak_test.in_one_channel(records, lambda part, row: np.array([test(row, part)[1]]),
                                                   halves)[0])
        if p_one >= level:
            reasons[i] = (f"{why[i]} and no spectral peak of its own at zeta {abs(zeta[i]):.3g} "
                          f"or {top[i]:.3g} (likelihood ratio {stat:.3g} summed, {own:.3g} in its shape; "
                          f"p-values {pvalue:.2g}, {p_own:.2g}, {p_one:.2g} in one of its {len(scaled)} "
                          f"channels; needs under {level:g})")


def shadows(omega: np.ndarray, zeta: np.ndarray, support: np.ndarray, scaled: np.ndarray, T: float,
            settled: np.ndarray) -> np.ndarray:
    """(k, k): whether candidate ``i`` must show a peak of its own because
    of candidate ``j`` (module docstring, shadows): MAC over ``SHADOW_MAC``
    and ``j`` better supported or ``settled[i]`` (its damping told from
    zero), or alike (:func:`alike` over ``PAIR_MAC``) and within the wider
    of their bands (:func:`identifier.modal.peak_test.half_width`, records
    of ``T`` s), whichever is better supported; candidates at ``omega``
    (k,) rad/s, damping ``zeta`` (k,), ``support`` (k,) stable poles,
    ``scaled`` (m, k) shapes in unit-RMS channels, ``settled`` (k,) bool."""
    k = omega.size
    if k < 2:
        return np.zeros((k, k), dtype=bool)
    half = peak_test.half_width(omega, zeta, T)
    near = np.abs(omega[:, None] - omega[None, :]) <= np.maximum(half[:, None], half[None, :])
    out = ((mac(scaled, scaled) > SHADOW_MAC) & ((support[None, :] > support[:, None]) | settled[:, None])
           | (alike(scaled) > PAIR_MAC) & near)
    np.fill_diagonal(out, False)
    return out


def unit_scaled(records: list[np.ndarray], shapes: np.ndarray) -> np.ndarray:
    """``shapes`` (m, k) with each channel divided by its RMS in the records
    (m, n_i) cut to the shortest (the channels of
    :func:`identifier.modal.peak_test.summed_periodogram`): shapes compared
    so that no channel of a large quantity (an acceleration beside
    displacements) makes unlike shapes alike."""
    n = min(y.shape[1] for y in records)
    rms = np.sqrt(np.mean([np.var(y[:, :n], axis=1) for y in records], axis=0))
    return shapes / np.where(rms > 0, rms, 1.0)[:, None]


def _apart(records: list[np.ndarray], dt: float, omega: np.ndarray, zeta: np.ndarray, omega_std: np.ndarray,
           support: np.ndarray, scaled: np.ndarray, reasons: list[str], open_: list[int], dropped: set[int]) -> None:
    """The projected test (module docstring): each candidate of ``open_``
    not rejected, with a better supported one of another shape inside its
    band and within ``REACH`` standard errors, tested on the periodogram of
    the channels projected on its shape apart from the shapes of the
    other-shaped candidates in its band (``dropped``: none of them);
    ``scaled`` (m, k): the shapes in unit-RMS channels (:func:`unit_scaled`)."""
    n = min(y.shape[1] for y in records)
    half = peak_test.half_width(omega, zeta, n * dt)
    se = np.where(np.isfinite(omega_std), omega_std, np.inf)
    like = alike(scaled)
    for c in open_:
        if c in dropped or reasons[c] or not np.linalg.norm(scaled[:, c]) > 0:
            continue
        near = [j for j in open_ if j != c and not reasons[j] and support[j] > support[c]
                and like[c, j] <= PAIR_MAC and abs(omega[j] - omega[c]) <= half[c]
                and abs(omega[j] - omega[c]) <= REACH * np.hypot(se[c], se[j])]
        if not near:
            continue
        u = scaled[:, c] / np.linalg.norm(scaled[:, c])
        V = scaled[:, [j for j in range(omega.size) if j != c and j not in dropped and like[c, j] <= PAIR_MAC
                       and abs(omega[j] - omega[c]) <= half[c]]]
        w = u - V @ np.linalg.lstsq(V, u, rcond=None)[0]
        if np.linalg.norm(w) < APART:
            continue
        stat, pvalue = peak_test.peak_lr(records, dt, omega, zeta, [c], excluded={c: sorted(dropped)},
                                         summed=peak_test.projected_periodogram(records, w / np.linalg.norm(w)))
        if pvalue[c] >= peak_test.ALPHA:
            reasons[c] = (f"no spectral peak of its own in its shape apart from the mode at "
                          f"{omega[near[0]]:.6g} rad/s (likelihood ratio {stat[c]:.3g}, p-value "
                          f"{pvalue[c]:.2g}; needs under {peak_test.ALPHA:g})")
