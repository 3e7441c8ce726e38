"""Maximum-likelihood refinement of the poles of the reported modes on free decays.

SSI-cov is not an efficient estimator: on a free decay its frequencies and
damping ratios spread 1-5 times the Cramer-Rao bound of the record
(docs/plan.md). This step fits the record itself, started from the SSI
poles, by maximum likelihood; its spread is the bound's.

Model. Record ``r`` (its free part, samples ``t_k = k dt`` from the start of
the free response, truncated as below), channel ``i``:

    y_ri(t_k) = a_ri + b_ri t_k + sum_j Re(c_rij exp(lambda_j t_k)) + e_ri(t_k),

``lambda_j = sigma_j + i omega_d,j`` shared by every record and channel,
complex amplitudes ``c_rij`` free per channel and record (what an
output-only identifier knows; displacement, velocity and acceleration
channels all carry the same poles), an offset and drift ``a + b t``
(sensor offsets, a rigid-body motion) and white Gaussian noise of standard
deviation ``s_ri``. The poles are the reported modes' and, as nuisance
terms, those of the candidate modes the support tests rejected (a mode the
record carries but SSI did not report would otherwise leave its signal in
the residual and pull the others); a close pair already fitted by
:mod:`identifier.modal.close_pairs` is held at its fit (its amplitudes
free), as is a mode refused below.

Equations. Each channel divided by its ``s_ri``, the records of one length
stack as ``Z = B(theta) C + E`` (n x M, one column per channel and record),
``B = [1, t, e^(sigma_j t) cos(omega_d,j t), e^(sigma_j t) sin(omega_d,j t), ...]``.
For given poles the amplitudes are linear least squares and are projected
out (variable projection, Golub and Pereyra 1973): ``theta = (sigma_j,
omega_d,j)`` minimises

    f(theta) = ||(I - P) Z||_F^2,     P = B (B^T B)^-1 B^T,

with Kaufman's Jacobian ``J_k = -(I - P) D_k C`` (``D_k = dB/dtheta_k``; for
pole ``j``'s columns ``u, v``: ``d/dsigma [u, v] = t [u, v]``, ``d/domega_d
[u, v] = t [-v, u]``). Every ``D_k C`` is ``T a_k`` with ``T = t [u_j, v_j]_j``
(n x 2p) and ``a_k`` pole ``j``'s amplitudes, so the Gauss-Newton quantities
need no ``n M x 2p`` Jacobian:

    J^T J = sum_m a_km^T W^T W a_lm,   W = (I - P) T,     J^T r = -sum_m a_km^T T^T r_m

(``r`` is orthogonal to ``B``; Kaufman's gradient is the exact one). They
drive Levenberg-Marquardt steps clipped to bounds until the Gauss-Newton
decrement ``g^T (J^T J)^-1 g`` of the reported poles falls under
``DECREMENT`` (the weighted cost is a chi-square: such a change is nothing).
Least squares on ``B`` use its Gram matrix (columns scaled, Cholesky, one
step of iterative refinement): matrix products only (a Householder QR of a
tall matrix, or ``scipy.optimize.least_squares`` and the SVD of the full
Jacobian at every step, cost 3-50 times more on a loaded machine). ``J^T J``
at the optimum is the Fisher information of the poles with every amplitude
eliminated (the Schur complement of the bound in
:mod:`structbench.planning.free_decay`), so the covariance is ``(f / dof)
(J^T J)^-1``, ``dof = sum n M - N M - 2p``; ``omega = |lambda|``, ``zeta =
-sigma / |lambda|`` and their standard errors follow by the delta method.
The noise levels ``s_ri`` are first the RMS of the residual of the SSI poles
with their ``t e^(lambda t)`` terms (which take up the SSI poles' errors),
then, after a first fit, of that fit's residual (each ``sum r^2 / (n -
N)``), and the fit is repeated with them.

Modes neither reported nor rejected. After the first fit the weighted
residual is searched for modes the model misses (a mode SSI did not see
leaves its signal there and, near a reported mode, biases it): the
periodogram ``sum_m 2 |DFT r_m|^2 / L`` of its first ``L = n, n/4, n/16, ...``
samples (a strongly damped mode lasts a small part of the record) is
``chi^2(2M)`` per bin under white noise; a peak further than ``NEAR`` bins
plus their decay rates from every pole, below level ``ALPHA`` Bonferroni
over the bins and lengths, gets a pole fitted there (the others held) and
joins the nuisance terms; at most ``MAX_ADDED``.

Cost. The record is truncated to ``DECAYS`` decay times ``1 / (zeta omega)``
of the slowest reported mode (past them every mode has lost all but
``e^-10`` of its energy: nothing is lost). Above ``BUDGET`` samples x
channels the weighted channels are first reduced to their ``2P + 2``
principal directions (the signal's rank: the rest is noise and carries
nothing on the poles), then the record is cut to the budget (a loss of
precision on the slowest modes, which the standard errors state). An
evaluation costs ``O(n N (N + M))``; the chapter 5 beam's free decay
(20,001 samples of 10 channels, 9 modes, 3 nuisance poles) takes about
1.5 CPU-s, a third of SSI-cov's own time.

Applies only to free decays: every trace a free response by its
``/excitation`` ``kind`` (``impulse`` or ``initial``, from the end of the
last impulse on; :func:`identifier.modal.close_pairs.free_start`), or,
without an excitation record, by its decay
(:func:`identifier.modal.ssi.covariance.is_free_decay`). A trace with any other
excitation (a force acting during the record) is refused.
Refused, the SSI answer kept (``details["ml_refinement"]`` says why):
``refine="off"``; not a free decay; too few samples for the poles; the fit
does not converge in ``MAX_ITERATIONS``. Per mode, the SSI answer is kept
(and the pole held at it in a refit of the others; a mode of damping ratio
outside (0, 1) is left out of the model) when its refined pole
moves more than ``MOVE`` SSI standard errors in ``omega`` or ``zeta``, ends
on a bound (half-way to the neighbouring poles in ``omega_d``; zero damping),
has no finite standard error, or when the residual says the model is wrong
there: a ``t e^(lambda t)`` term at the pole (a second mode within its
bandwidth that neither SSI nor the search resolved, whose signal the fit
would bend the pole to) by the score test of
:func:`identifier.modal.close_pairs.pair.score_statistics` (``chi^2(2M -
2)``, p-value below ``MISFIT`` Bonferroni over the modes; one channel of
one record has no such test). With ``uncertainty="off"`` SSI states no
errors: the refined values are reported (the same as the default run's
wherever that run's move test passes) without errors (NaN), and only the
bounds limit a move.

Assumptions and failures: a linear structure in free response from the
record's start (no force after it), white noise on every channel, every
mode with signal in the record among the poles or found by the search. A
mode too weak for the search stays in the residual: it inflates ``s`` (the
errors get larger) and, if near a reported mode, biases it; so does a mode
the search fits badly (two close unseen modes as one pole). Non-white noise
(a filtered sensor) makes the stated errors too small. The stated errors
are the bound's (no scatter over model orders, no bias term): the fit is
efficient only where the model holds. Shapes are SSI's.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.linalg as la
from scipy.stats import chi2

from ..io.traces import Trace
from .close_pairs import free_start
from .close_pairs.free_decay_fit import Group, basis, omega_zeta, project
from .close_pairs.pair import score_statistics
from .runtime import one_blas_thread
from .ssi.covariance import is_free_decay

DECAYS = 5.0  # record used: this many decay times 1 / (zeta omega) of the slowest reported mode
MOVE = 4.0  # largest move of a refined pole from SSI's, in SSI standard errors (omega and zeta each)
BUDGET = 4_000_000  # samples x channels fitted at most
MAX_ITERATIONS = 50  # Levenberg-Marquardt iterations of one fit
DECREMENT = 1e-4  # converged: the Gauss-Newton step lowers the cost (a chi-square) by less
MAX_NUISANCE_ZETA = 0.5  # rejected candidates more damped than this are no nuisance terms
FLOOR = 1e-6  # least noise standard deviation, x the channel's RMS
ALPHA = 0.01  # level of the search for modes missing from the model (Bonferroni over bins and lengths)
NEAR = 2.0  # frequency bins around a pole (plus its decay rate) that belong to it in that search
MIN_SEARCH = 64  # shortest stretch of the record searched
MAX_ADDED = 8  # poles found in the residual (modes neither reported nor rejected) at most
MISFIT = 1e-3  # a refined pole whose residual holds a t e^(lambda t) term at this p-value keeps SSI's answer
ROUNDS = 3  # fits at most: a refused pole is held at SSI's and the others fitted again


@dataclass(frozen=True)
class PoleRefinement:
    """The modes after the refinement (the input's order): ``omega`` rad/s,
    ``zeta``, their standard errors, ``applied`` (k,) True where they come
    from the fit, and ``details`` (``details["ml_refinement"]`` of the results)."""

    omega: np.ndarray
    zeta: np.ndarray
    omega_std: np.ndarray
    zeta_std: np.ndarray
    applied: np.ndarray
    details: dict[str, Any] = field(default_factory=dict)


def free_starts(traces: Sequence[Trace], records: Sequence[np.ndarray]) -> list[int] | str:
    """The first sample of each trace's free response, or why a trace is no
    free decay: by the ``/excitation`` ``kind`` when the trace has one
    (``impulse``/``initial`` only), else by its decay (:func:`is_free_decay`)."""
    starts = []
    for trace, y in zip(traces, records):
        start = free_start(trace)
        if start is None:
            kind = str(trace.excitation_attrs.get("kind", ""))
            if kind:
                return f"{trace.path.name}: excitation {kind!r} is no free decay"
            if not is_free_decay(y):
                return f"{trace.path.name}: the record does not decay (no free decay)"
            start = 0
        if y.shape[1] - start < 4:
            return f"{trace.path.name}: no free response after sample {start}"
        starts.append(start)
    return starts


def _unchanged(omega, zeta, omega_std, zeta_std, reason: str, ssi: dict | None = None) -> PoleRefinement:
    return PoleRefinement(omega, zeta, omega_std, zeta_std, np.zeros(omega.size, bool),
                          {"applied": False, "reason": reason, "modes": [False] * omega.size,
                           "mode_reasons": [reason] * omega.size} | ({"ssi": ssi} if ssi else {}))


def _poles(omega: np.ndarray, zeta: np.ndarray) -> np.ndarray:
    return -zeta * omega + 1j * omega * np.sqrt(np.maximum(1 - zeta**2, 0.0))


def nuisance_poles(candidates: Sequence[tuple[float, float]], poles: np.ndarray, dt: float, span: float
                   ) -> np.ndarray:
    """The poles of rejected candidate modes ``(omega, zeta)`` that the fit
    takes as nuisance terms: under 0.99 x Nyquist, ``0 < zeta <
    MAX_NUISANCE_ZETA``, lasting 10 samples or more, and resolved from every
    other pole (``|delta omega_d| > 2 pi / span + sigma_a + sigma_b``)."""
    kept = list(poles)
    out = []
    for w, z in sorted(candidates, key=lambda c: c[0]):
        if not (np.isfinite(w) and np.isfinite(z) and 0 < w < 0.99 * np.pi / dt and 0 < z < MAX_NUISANCE_ZETA):
            continue
        if z * w * dt > 0.1:
            continue
        lam = _poles(np.array([w]), np.array([z]))[0]
        if all(abs(lam.imag - p.imag) > 2 * np.pi / span - lam.real - p.real for p in kept):
            kept.append(lam)
            out.append(lam)
    return np.array(out, dtype=complex)


@dataclass
class _Data:
    """Groups of equal length: times ``t`` (n,), raw data ``y`` (n, M), noise levels ``s`` (M,)."""

    t: list[np.ndarray]
    y: list[np.ndarray]
    s: list[np.ndarray]


def _noise(t: np.ndarray, y: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """Per column the RMS of the residual of ``y`` (n, M) on ``columns`` (n, N), ``sum r^2 / (n - N)``."""
    try:
        r = _Solver(columns).coefficients(y)[1]
    except la.LinAlgError:
        q, _ = la.qr(columns, mode="economic")
        r = y - q @ (q.T @ y)
    s = np.sqrt(np.sum(r**2, axis=0) / max(t.size - columns.shape[1], 1))
    return np.maximum(s, FLOOR * np.sqrt(np.mean(y**2, axis=0)) + np.finfo(float).tiny)


def _weighted(data: _Data, rank: int, budget: int) -> tuple[list[np.ndarray], list[np.ndarray], int]:
    """The weighted groups (times, data) within ``budget`` samples x
    channels: each group's channels reduced to their ``rank`` principal
    directions (the signal's rank) where it has more, then fewer samples.
    Returns them and the samples kept."""
    ts, zs = list(data.t), [y / s for y, s in zip(data.y, data.s)]
    if sum(z.size for z in zs) > budget:
        zs = [z @ la.svd(z, full_matrices=False)[2][:rank].T if z.shape[1] > rank else z for z in zs]
    cut = max(t.size for t in ts)
    if sum(z.size for z in zs) > budget:
        cut = max(int(budget / sum(z.shape[1] for z in zs)), 8 * rank)
        ts, zs = [t[:cut] for t in ts], [z[:cut] for z in zs]
    return ts, zs, cut


class _Solver:
    """Least squares on a tall basis ``b`` (n, N) by its Gram matrix (columns
    scaled to unit norm, Cholesky, one step of iterative refinement per
    solve): matrix products only. A Householder QR of a tall matrix runs
    N level-2 BLAS passes, each on every BLAS thread: 10-50 times slower
    on a loaded machine."""

    def __init__(self, b: np.ndarray) -> None:
        self.scale = np.maximum(np.sqrt(np.einsum("ij,ij->j", b, b)), np.finfo(float).tiny)
        self.b = b / self.scale
        self.factor = la.cho_factor(self.b.T @ self.b)

    def coefficients(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Coefficients (N, M) of the scaled columns and the residual (n, M) of ``z`` (n, M)."""
        c = la.cho_solve(self.factor, self.b.T @ z)
        r = z - self.b @ c
        c += la.cho_solve(self.factor, self.b.T @ r)
        return c, z - self.b @ c


class _Fit:
    """Variable projection over groups ``(t, z)`` with poles ``fixed`` held
    (their columns in the basis) and the free ones' ``(sigma, omega_d)``
    interleaved in ``x``: the cost ``f`` and, from small products, the
    Gauss-Newton gradient and information (no ``n M x 2p`` Jacobian)."""

    def __init__(self, ts: list[np.ndarray], zs: list[np.ndarray], fixed: np.ndarray) -> None:
        self.ts, self.zs = ts, zs
        self.fixed_cols = [basis(t, fixed)[:, 2:] for t in ts]

    def state(self, x: np.ndarray) -> tuple[float, list[tuple]]:
        """``f`` and per group the basis, its solver, the amplitudes ``C`` (of
        the unscaled columns) and the residual ``R``; ``f`` infinite where the
        basis is singular."""
        poles = x[0::2] + 1j * x[1::2]
        out, f = [], 0.0
        for t, z, fc in zip(self.ts, self.zs, self.fixed_cols):
            b = np.column_stack([basis(t, poles), fc])
            try:
                solver = _Solver(b)
            except la.LinAlgError:
                return np.inf, []
            c, r = solver.coefficients(z)
            f += float(np.sum(r**2))
            out.append((b, solver, c / solver.scale[:, None], r))
        return f, out

    @staticmethod
    def normal(ts: list[np.ndarray], states: list[tuple], p: int) -> tuple[np.ndarray, np.ndarray]:
        """Gradient ``J^T r`` (2p,) and information ``J^T J`` (2p, 2p) of
        Kaufman's Jacobian ``-(I - P) D_k C`` (``P`` the projector on the
        basis): every ``D_k C`` is ``T a_k`` (``T = t [u_j, v_j]_j``, ``a_k`` from
        pole ``j``'s amplitudes), so ``J^T J = sum_m a^T W^T W a`` with ``W =
        (I - P) T`` and ``J^T r = -sum_m a^T T^T r_m`` (``r`` is orthogonal to the basis)."""
        grad, info = np.zeros(2 * p), np.zeros((2 * p, 2 * p))
        for t, (b, solver, coef, r) in zip(ts, states):
            tt = b[:, 2:2 + 2 * p] * t[:, None]
            _, w = solver.coefficients(tt)
            gram = w.T @ w
            tr = tt.T @ r  # (2p, M)
            m = r.shape[1]
            c = coef[2:2 + 2 * p].reshape(p, 2, m)
            a = np.zeros((2 * p, 2 * p, m))  # [parameter, column of T, channel]
            j = np.arange(p)
            a[2 * j, 2 * j], a[2 * j, 2 * j + 1] = c[:, 0], c[:, 1]  # d/dsigma_j: (c_u, c_v)
            a[2 * j + 1, 2 * j], a[2 * j + 1, 2 * j + 1] = c[:, 1], -c[:, 0]  # d/domega_d,j: (c_v, -c_u)
            ag = np.einsum("kam,ab->kbm", a, gram)
            info += np.einsum("kbm,lbm->kl", ag, a)
            grad -= np.einsum("kam,am->k", a, tr)
        return grad, 0.5 * (info + info.T)


def _fit(ts, zs, fixed: np.ndarray, start: np.ndarray, lower: np.ndarray, upper: np.ndarray,
         watch: int | None = None) -> tuple[np.ndarray, np.ndarray, bool, np.ndarray]:
    """Free poles (p,) fitted from ``start`` by Levenberg-Marquardt on the
    normal equations (steps clipped to the bounds), their covariance (2p, 2p)
    of ``(sigma, omega_d)``, whether it converged (the Gauss-Newton decrement
    ``g^T H^-1 g``, what a full step would lower the cost by, under
    ``DECREMENT``: the data are in units of their noise, so the cost is a
    chi-square and such a change is nothing; parameters on a bound that the
    step would push out held there), and which ended on a bound (p,). With
    ``watch``, only the first ``watch`` poles' share of the decrement counts
    (the step's move of them in their own standard errors, squared): a
    nuisance pole of a mode the model fits badly may creep on for long
    without moving them.)"""
    fit = _Fit(ts, zs, fixed)
    p = start.size
    x = np.clip(np.column_stack([start.real, start.imag]).ravel(), lower, upper)
    f, states = fit.state(x)
    if not np.isfinite(f):
        return start, np.full((x.size, x.size), np.nan), False, np.zeros(p, bool)
    damping, converged = 1e-3, False
    width = upper - lower
    for _ in range(MAX_ITERATIONS):
        g, h = fit.normal(ts, states, p)
        # parameters on a bound that the descent direction pushes out stay there
        held = ((x - lower < 1e-9 * width) & (g > 0)) | ((upper - x < 1e-9 * width) & (g < 0))
        move = np.flatnonzero(~held)
        hm, gm = h[np.ix_(move, move)], g[move]
        scale = np.maximum(np.diag(hm), np.finfo(float).tiny)
        try:
            full = la.solve(hm, gm, assume_a="pos")
            if watch is None or watch >= p:
                decrement = float(gm @ full)
            else:
                mine = move < 2 * watch
                cw = la.inv(hm)[np.ix_(mine, mine)]
                decrement = float(full[mine] @ la.solve(cw, full[mine], assume_a="pos"))
        except (la.LinAlgError, ValueError):
            decrement = np.inf
        if decrement < DECREMENT:  # the Gauss-Newton step would lower the cost by less: converged
            converged = True
            break
        for _ in range(30):
            step = np.zeros_like(x)
            try:
                step[move] = -la.solve(hm + damping * np.diag(scale), gm, assume_a="pos")
            except (la.LinAlgError, ValueError):
                step[:] = np.nan
            if np.all(np.isfinite(step)):
                trial = np.clip(x + step, lower, upper)
                f_new, st_new = fit.state(trial)
                if f_new <= f:
                    break
            damping *= 4.0
        else:
            break  # no step lowers the cost
        x, f, states = trial, f_new, st_new
        damping = max(damping / 3.0, 1e-9)
    g, h = fit.normal(ts, states, p)
    n_lin = 2 + 2 * (p + fixed.size)
    dof = sum(z.size for z in zs) - n_lin * sum(z.shape[1] for z in zs) - x.size
    try:
        cov = f / max(dof, 1) * la.inv(h)
    except (la.LinAlgError, ValueError):
        cov = np.full((x.size, x.size), np.nan)
    edge = (np.abs(x - lower) < 1e-6 * width) | (np.abs(upper - x) < 1e-6 * width)
    return x[0::2] + 1j * x[1::2], cov, converged, edge.reshape(-1, 2).any(axis=1)


def residual_peak(resids: list[np.ndarray], poles: np.ndarray, dt: float) -> tuple[float, float, float] | None:
    """The most significant peak (frequency rad/s, decay rate 1/s, p-value)
    of the residuals (n_g, M_g; unit white noise under the null) away from
    every pole, or None above ``ALPHA``. A free decay's mode lasts ``1 / sigma``,
    often a small part of the record, and its energy spreads over ``sigma``
    rad/s of the whole record's periodogram: the search runs over the first
    ``L = n, n/4, n/16, ...`` samples (down to ``MIN_SEARCH``), the periodogram
    ``P = sum_m 2 |DFT r_m|^2 / L`` of each is ``chi^2(2M)`` per bin, bins within
    ``NEAR`` bins plus a pole's decay rate of it excluded; p-values
    Bonferroni over the bins and the lengths."""
    n = max(r.shape[0] for r in resids)
    lengths = []
    length = n
    while length >= MIN_SEARCH:
        lengths.append(length)
        length //= 4
    best = None
    for length in lengths:
        power = sum(2 * np.sum(np.abs(np.fft.rfft(r[:length], axis=0)) ** 2, axis=1) / length
                    for r in resids if r.shape[0] >= length)
        columns = sum(r.shape[1] for r in resids if r.shape[0] >= length)
        step = 2 * np.pi / (length * dt)
        freq = np.arange(power.size) * step
        ok = (freq > 0) & (freq < np.pi / dt)
        ok &= np.all(np.abs(freq[:, None] - poles.imag[None, :]) > NEAR * step - poles.real[None, :], axis=1)
        if not ok.any():
            continue
        b = int(np.argmax(np.where(ok, power, -np.inf)))
        p = chi2.sf(power[b], 2 * columns) * ok.sum() * len(lengths)
        if p < ALPHA and (best is None or p < best[2]):
            best = (float(freq[b]), 1.0 / (length * dt), float(p))
    return best


def _missing(ts: list[np.ndarray], zs: list[np.ndarray], poles: np.ndarray, dt: float) -> np.ndarray:
    """Poles of modes the model misses: while the weighted residual has a
    significant peak away from every pole (:func:`residual_peak`), a pole
    fitted there (within a bin of the peak, the others held); at most ``MAX_ADDED``."""
    added: list[complex] = []
    for _ in range(MAX_ADDED):
        every = np.concatenate([poles, added])
        try:
            resids = [_Solver(basis(t, every)).coefficients(z)[1] for t, z in zip(ts, zs)]
        except la.LinAlgError:
            break
        peak = residual_peak(resids, every, dt)
        if peak is None:
            break
        w0, rate, _ = peak
        step = 2 * np.pi * rate
        lower = np.array([-2 * w0, max(w0 - step, 0.5 * w0)])
        upper = np.array([-1e-9 * w0, min(w0 + step, np.pi / dt)])
        stretch = int(np.ceil(4 / (rate * dt)))  # where the peak shows: fitted there
        lam, _, _, _ = _fit([t[:stretch] for t in ts], [z[:stretch] for z in zs], every,
                            np.array([complex(-min(rate, 0.5 * w0), w0)]), lower, upper)
        added.append(complex(lam[0]))
    return np.array(added, dtype=complex)


def _misfit(ts: list[np.ndarray], zs: list[np.ndarray], poles: np.ndarray, tested: int) -> np.ndarray:
    """Per tested pole (the first ``tested`` of ``poles``) the p-value
    (Bonferroni over them) of the score test for a ``t e^(lambda t)`` term
    in the weighted residual (:func:`identifier.modal.close_pairs.pair.score_statistics`,
    ``chi^2(2M - 2)``): an unresolved second mode or another misfit at the pole."""
    groups = [Group(t, z) for t, z in zip(ts, zs)]
    try:
        projections = [project(g, basis(g.t, poles)) for g in groups]
    except (la.LinAlgError, ValueError):
        return np.zeros(tested)
    stats, df = score_statistics(groups, projections, poles, tested)
    return np.minimum(chi2.sf(stats, df) * tested, 1.0) if df > 0 else np.ones(tested)


def _bounds(free: np.ndarray, fixed: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Per free pole (at its anchor ``free``) ``sigma`` within ``[-2 |lambda|,
    -1e-9 |lambda|]`` and ``omega_d`` within half-way to the nearest other pole,
    free or ``fixed`` (and Nyquist)."""
    lower, upper = [], []
    nyquist = np.pi / dt
    everyone = np.concatenate([free, fixed]).imag
    for i, lam in enumerate(free):
        others = np.delete(everyone, i)
        below, above = others[others < lam.imag], others[others >= lam.imag]
        lo = (lam.imag + below.max()) / 2 if below.size else 0.5 * lam.imag
        hi = (lam.imag + above.min()) / 2 if above.size else min(1.5 * lam.imag, nyquist)
        mag = abs(lam)
        lower += [-2 * mag, lo]
        upper += [-1e-9 * mag, min(hi, nyquist)]
    return np.array(lower), np.array(upper)


def refine_poles(traces: Sequence[Trace], records: Sequence[np.ndarray], dt: float, omega: np.ndarray,
                 zeta: np.ndarray, omega_std: np.ndarray, zeta_std: np.ndarray, held: np.ndarray,
                 candidates: Sequence[tuple[float, float]], refine: str) -> PoleRefinement:
    """The modes (``omega`` rad/s, ``zeta``, their standard errors; ``held``
    (k,) True for modes not to refine, e.g. a close-pair fit's) with their
    poles refined by maximum likelihood on the traces' free decays
    (``records`` (m, n) per trace), ``candidates`` ``(omega, zeta)`` of the
    rejected SSI modes as nuisance terms; the SSI answer where refused
    (module docstring). ``refine``: ``auto`` or ``off``."""
    omega, zeta = np.asarray(omega, float), np.asarray(zeta, float)
    omega_std, zeta_std = np.asarray(omega_std, float), np.asarray(zeta_std, float)
    ssi = {"omega": omega.tolist(), "damping": zeta.tolist(), "omega_std": omega_std.tolist(),
           "damping_std": zeta_std.tolist()}
    if refine == "off":
        return _unchanged(omega, zeta, omega_std, zeta_std, "refine=off")
    k = omega.size
    if k == 0:
        return _unchanged(omega, zeta, omega_std, zeta_std, "no mode reported")
    starts = free_starts(traces, records)
    if isinstance(starts, str):
        return _unchanged(omega, zeta, omega_std, zeta_std, starts)
    trusted = np.isfinite(omega_std) & np.isfinite(zeta_std) & (omega_std > 0) & (zeta_std > 0)
    modelled = (zeta > 0) & (zeta < 1)  # a pole that does not decay, or no oscillation: left out
    todo = ~np.asarray(held, bool) & modelled
    if not todo.any():
        return _unchanged(omega, zeta, omega_std, zeta_std, "no mode to refine (close-pair fits, damping "
                          "outside (0, 1))", ssi)
    poles = _poles(omega, zeta)
    free_len = [y.shape[1] - s for y, s in zip(records, starts)]
    n = min(max(free_len), int(np.ceil(DECAYS / np.min((zeta * omega)[modelled]) / dt)))
    nuisance = nuisance_poles(candidates, poles[modelled], dt, n * dt)
    data = _Data([], [], [])
    first_cols = None
    for length in sorted({min(f, n) for f in free_len}):
        cols = [y[:, s:s + length].T for y, s, f in zip(records, starts, free_len) if min(f, n) == length]
        t = np.arange(length) * dt
        y = np.hstack(cols)
        every = np.concatenate([poles[modelled], nuisance])
        b = basis(t, every)
        first_cols = np.column_stack([b, t[:, None] * b[:, 2:]])
        if first_cols.shape[1] >= length:
            return _unchanged(omega, zeta, omega_std, zeta_std,
                              f"{length} samples are too few for {every.size} poles", ssi)
        data.t.append(t)
        data.y.append(y)
        data.s.append(_noise(t, y, first_cols))
    refused = np.zeros(k, bool)
    reasons = ["held (close-pair fit)" if h else "" if ok else "damping ratio outside (0, 1): not refined"
               for h, ok in zip(held, modelled)]
    out_w, out_z, out_sw, out_sz = omega.copy(), zeta.copy(), omega_std.copy(), zeta_std.copy()
    applied = np.zeros(k, bool)
    cut, added = n, 0
    with one_blas_thread():
        for round_ in range(ROUNDS):
            active = todo & ~refused
            if not active.any():
                break
            p = int(active.sum())
            fixed = poles[~active & modelled]
            free = np.concatenate([poles[active], nuisance])
            for sweep in range(2):  # weights of the SSI poles, then of the first fit's residual
                lower, upper = _bounds(np.concatenate([poles[active], nuisance]), fixed, dt)  # SSI's anchor
                ts, zs, cut = _weighted(data, 2 * (free.size + fixed.size) + 2, BUDGET)
                fitted, cov, ok, edge = _fit(ts, zs, fixed, free, lower, upper, watch=p)
                if not ok:
                    return _unchanged(omega, zeta, omega_std, zeta_std, "the fit did not converge", ssi)
                if sweep == 1:
                    break
                if round_ == 0:  # modes the model misses, found in the fit's residual: nuisance terms too
                    found = _missing(ts, zs, np.concatenate([fitted, fixed]), dt)
                    added = found.size
                    nuisance = np.concatenate([fitted[p:], found])
                else:
                    nuisance = fitted[p:]
                free = np.concatenate([fitted[:p], nuisance])
                for g, t in enumerate(data.t):
                    data.s[g] = _noise(t, data.y[g], basis(t, np.concatenate([free, fixed])))
            idx = np.flatnonzero(active)
            w, z, se_w, se_z = (v[:p] for v in omega_zeta(fitted, cov))  # the nuisance poles last
            misfit = _misfit(ts, zs, np.concatenate([fitted, fixed]), p)
            good = np.zeros(p, bool)
            for a, i in enumerate(idx):
                moved = max(abs(w[a] - omega[i]) / omega_std[i], abs(z[a] - zeta[i]) / zeta_std[i]) \
                    if trusted[i] else 0.0  # no SSI errors (uncertainty="off"): no move to bound
                if edge[a]:
                    reasons[i] = "the refined pole ended on a bound"
                elif misfit[a] < MISFIT:
                    reasons[i] = f"the residual holds a t e^(lambda t) term at the pole (p = {misfit[a]:.2g})"
                elif not (np.isfinite(se_w[a]) and np.isfinite(se_z[a]) and se_w[a] > 0 and se_z[a] > 0):
                    reasons[i] = "no finite refined standard error"
                elif moved > MOVE:
                    reasons[i] = f"moved {moved:.3g} SSI standard errors (over {MOVE:g})"
                else:
                    reasons[i] = "refined"
                    good[a] = True
            if good.all() or round_ == ROUNDS - 1:  # the last round: its good poles, the others held
                use = idx[good]
                out_w[use], out_z[use] = w[good], z[good]
                errors = trusted[use]  # without SSI's errors (uncertainty="off") none are stated
                out_sw[use] = np.where(errors, se_w[good], np.nan)
                out_sz[use] = np.where(errors, se_z[good], np.nan)
                applied[use] = True
                break
            refused[idx[~good]] = True
    for i in np.flatnonzero(todo & ~applied):
        reasons[i] += " (SSI kept)"
    details = {"applied": bool(applied.any()), "reason": "" if applied.any() else "every mode refused",
               "modes": applied.tolist(), "mode_reasons": reasons, "samples": int(min(cut, n)),
               "nuisance": sorted(float(abs(p)) for p in nuisance), "found_in_residual": int(added),
               "ssi": ssi}
    return PoleRefinement(out_w, out_z, out_sw, out_sz, applied, details)
