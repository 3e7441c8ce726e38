"""Sensor offsets: transients of known shape in the prefiltered equations, estimated with the parameters.

What a constant does to the filter. The prefilter
(:mod:`identifier.least_squares.prefilter`) starts at rest at the first
sample ``t_0``; a channel carrying a constant offset ``c`` (a displacement
probe's zero, an accelerometer's or velocity sensor's DC bias) therefore
feeds it a step ``c H(t - t_0)``. With ``P = lam / (s + lam)`` and
``lam (1 - P) = s P``, the slot filter ``lam^d (1 - P)^d P^(r - d)`` of
that step gives ``c phi_d(t)``,

    phi_d = step response of  lam^r s^d / (s + lam)^r
    phi_0(t) = 1 - exp(-lam t) sum_(i < r) (lam t)^i / i!     (a constant after the rise)
    phi_1(t) = lam^r t^(r-1) exp(-lam t) / (r - 1)!            (an Erlang bump at (r - 1) / lam)
    phi_d    = d^(d-1)/dt^(d-1) phi_1                          (d >= 1: transients only)

(``t`` from ``t_0``). Only the low-pass slot (``d = 0``, a displacement
measured where every DOF is a displacement, ``e = 0``) keeps the constant;
every high-pass stage turns it into a transient gone after ``(r + 8) / lam``
s or so. A displacement offset ``u0`` alone (``e = 0``) adds to the filtered
equations ``(K u0) phi_0 + (C u0) phi_1 + (M u0) phi_2``: the constant
generalised force ``K u0`` plus transients. In general an offset on a
channel of level ``ell`` reaches slot ``sigma`` through ``phi_(e + sigma - ell)``,
and an initial state ``u(t_0)``, ``v(t_0)`` other than rest adds
``L (M (s u0 + v0) + C u0)`` (``L = s^e P^r``), also a combination of the
``phi_d`` (up to the discretisation): every DOF row ``i`` of every record satisfies

    M (L a) + C (L v) + K (L u) - L f = sum_(d = 0..e+2) b_(i,d) phi_d(t) + noise,    (*)

with ``b_(i,d) = sum_j Mt[slot of DOF j with filter d, i] c_j`` for offsets
``c`` (``Mt`` of :mod:`identifier.least_squares.whitened`; e.g.
``b_0 = K u0``, ``b_1 = C u0``, ``b_2 = M u0`` above).

Estimator. ``b`` free per row would be linear, but an impulse at ``t_0`` is
``L f = F phi_(e+1)`` (a force held over the first sample, or an initial
velocity): a free ``b_(i,e+1)`` takes it, and with it the scale of ``M``,
``C``, ``K``. So the ``phi_d`` with ``d != e + 1`` get free coefficients, and
the ``phi_(e+1)`` term its structured value at the previous estimate
(``(C u0) phi_1`` above, added to the force slot), iterated. Free
coefficients shared by all rows are eliminated by one projection of every
slot of the record (Frisch-Waugh-Lovell), ``x <- Q x``, ``Q = I - U U^T``,
``U`` (m, q) an orthonormal basis of the sampled free ``phi_d`` (the slot
filters' own step responses, so exact in discrete time); the regression
keeps its form. Noise: ``sum_k E[(Q xi)_k (Q xi')_k] = sum_k E[xi_k xi'_k] -
sum_l sigma_l^2 sum_q (h^T u_q)_l (h'^T u_q)_l`` (:func:`noise_correction`,
subtracted by the bias compensation); the first-order standard errors of
:mod:`identifier.least_squares.colored` need nothing more (``Q`` symmetric
idempotent: ``sum_k (Q B)_k (Q xi)_k = sum_k (Q B)_k xi_k``). The offsets
``c`` (:func:`fit`): least squares of the removed part of the equations,
``U^T X Mt`` (q, n), on the offsets' patterns at the latest estimate. The
iteration contracts by about ``|b_(e+1)| / |F|`` per solve (0.1 for the
1 mm offset and 0.1 N s impulse of the 1-DOF oscillator below); it stops
when no parameter moves by :data:`TOLERANCE` of its value (at most
:data:`ITERATIONS` solves). The fixed term's own error (from the estimates'
errors, about ``|b_(e+1)| / |F|`` of them) is left out of the standard errors.

Measured (1-DOF, 1 kg, 1e4 N/m, 10 N s/m; 2 % noise on displacement and
force, five 4 s impulse records): with the offsets estimated where there
are none, the standard errors of m, c, k change by < 3 %; with a 1 mm
offset, m, c, k are as good as without one (benchmarks/foreign_fmu.py).

When. Estimating offsets costs precision (the projection, and ``n``
more unknowns per record) and fails where they are confounded with the
motion: a free structure's rigid-body modes (a velocity offset in a
rigid-body shape *is* a rigid-body motion), records no longer than the
signatures. So the offsets are estimated only when they show: the at-rest
estimate's equation errors along the free signatures, ``x = vec(U^T X Mt)``
(q n per record), have the first-order noise covariance ``Sigma`` (every
source through the adjoint slot filters, as above), and
``chi^2 = x^T Sigma^+ x`` (:func:`statistic`; summed over records, degrees of
freedom the ranks) beyond its ``1 -`` :data:`SIGNIFICANCE` quantile switches
them on (``details.prefilter.offsets_test``). Without offsets it stays
near its degrees of freedom (chapter 3 beam, 2 % noise: 50-66 on 64),
and the estimate is the at-rest one, unchanged; on the 1-DOF oscillator
below (five records, 10 degrees of freedom) 6-20 without an offset, 1e5
with 10 um (a tenth of the response's RMS), 2e4 with 1 mm (the noise, 2 %
of the RMS with the offset, ten times larger).

Reported: ``c`` per record and response channel, in the channel's unit,
without standard errors; an initial state other than rest reads as offsets.

Costs and failures. The projection takes from the parameters what the
response shares with the free ``phi_d``: mostly the record's mean (the static
deflection, when ``e = 0``: a constant load and a displacement offset are
then indistinguishable, so (quasi-)static tests fail) and the first
``(r + 8) / lam`` s. Not covered: offsets that change during the record
(drift, a zero that steps mid-record), force offsets (a constant force is a
load; its held filter matches the slots' only to ``O(lam dt)``), offsets of
the order of the impulse's ``|F| / |b_(e+1)|`` or beyond (the iteration
stops contracting).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .prefilter import Design, SlotFilter

ITERATIONS = 12  # solves at most (each re-fixes the phi_(e+1) part from the latest estimate)
MEMORY = 4  # iterates mixed by the Anderson acceleration
TOLERANCE = 1e-5  # stop when no parameter moves by more than this share of its value
RANK_TOL = 1e-9  # sampled phi_d with singular values below this share of the largest are dropped
SIGNIFICANCE = 1e-6  # offsets estimated when the at-rest estimate's chi^2 along the signatures is this unlikely


@dataclass(frozen=True)
class Steps:
    """A record's offset signatures. ``functions`` (m, n_f): the step
    responses ``phi_d`` of its response slot filters, ``d`` (n_f,); ``of``
    (4 n,): which one each raw slot carries (-1: none, the force); ``U`` (m, q):
    orthonormal basis of the free ones (``d != e + 1``); ``removed`` (q, 4 n):
    the raw slots' coordinates along ``U`` (taken off them by :func:`projected`); ``fixed``
    (m,): the projected ``phi_(e+1)`` (zeros if no slot carries it), ``fixed_d`` = e + 1."""

    functions: np.ndarray
    d: np.ndarray
    of: np.ndarray
    U: np.ndarray
    removed: np.ndarray
    fixed: np.ndarray
    fixed_d: int

    def signature(self) -> np.ndarray:
        """``A`` (n_f, 4 n): 1 where raw slot ``c`` carries step response ``f``."""
        A = np.zeros((self.functions.shape[1], self.of.size))
        live = np.flatnonzero(self.of >= 0)
        A[self.of[live], live] = 1.0
        return A


def signatures(slots: np.ndarray, sources: Sequence, design: Design) -> Steps:
    """The :class:`Steps` of a record's response ``sources`` (blocks 0 a, 1 v,
    2 u) and raw slots ``slots`` (m, 4 n), which stay as they are."""
    m, n4 = slots.shape
    n = n4 // 4
    functions, d, index, of = [], [], {}, np.full(n4, -1)
    for src in sources:
        if 3 in src.blocks:
            continue
        for b, f in zip(src.blocks, src.filters):
            if f not in index:
                index[f] = len(functions)
                functions.append(f(np.ones(m)))
                d.append(f.d)
            of[b * n + src.dofs] = index[f]
    S, d = np.column_stack(functions), np.array(d)
    free = S[:, d != design.e + 1]
    u, sv, _ = np.linalg.svd(free, full_matrices=False)
    U = u[:, sv > RANK_TOL * sv.max()]
    one = S[:, d == design.e + 1]
    fixed = one[:, 0] - U @ (U.T @ one[:, 0]) if one.size else np.zeros(m)
    return Steps(S, d, of, U, U.T @ slots, fixed, design.e + 1)


def projected(rec):
    """``rec`` (a :class:`identifier.least_squares.colored.Record` with
    ``steps``) with every slot projected, ``x <- x - U U^T x``."""
    from dataclasses import replace

    from . import Motion

    mo, st = rec.motion, rec.steps
    n = mo.force.shape[1]
    taken = st.U @ st.removed  # (m, 4 n)
    a, v, u, f = (getattr(mo, q) - taken[:, b * n:(b + 1) * n]
                  for b, q in enumerate(("acceleration", "velocity", "displacement", "force")))
    return replace(rec, motion=Motion(mo.times, u, v, a, f, mo.sigma), projected=True)


def statistic(records: Sequence, mt: np.ndarray) -> tuple[float, int]:
    """``chi^2`` of the equations' components along the free signatures at
    ``Mt`` (4 n, n) (an estimate that assumed no offsets), against their noise
    covariance (first order, every source through its slot filters), and
    its degrees of freedom (the covariance's rank), summed over records."""
    n = mt.shape[1]
    chi2, dof = 0.0, 0
    for rec in records:
        st = rec.steps
        q = st.U.shape[1]
        x = (st.removed @ mt).ravel()  # (q n,)
        cov = np.zeros((q, n, q, n))
        for src in rec.sources:
            G = [f(st.U, reverse=True) for f in src.filters]  # (m, q) each
            for b, gb in zip(src.blocks, G):
                for b2, gb2 in zip(src.blocks, G):
                    cj = np.einsum("lj,lq,lp->jqp", src.sigma**2, gb, gb2, optimize=True)
                    cov += np.einsum("jr,js,jqp->qrps", mt[b * n + src.dofs], mt[b2 * n + src.dofs], cj,
                                     optimize=True)
        w, V = np.linalg.eigh(cov.reshape(q * n, q * n))
        keep = w > RANK_TOL * max(w.max(initial=0.0), np.finfo(float).tiny)
        chi2 += float(np.sum((V[:, keep].T @ x) ** 2 / w[keep]))
        dof += int(keep.sum())
    return chi2, dof


def noise_correction(sigma: np.ndarray, U: np.ndarray, f: SlotFilter, g: SlotFilter) -> np.ndarray:
    """What the projection takes off ``sum_k E[xi_k xi'_k]`` for white noise
    ``sigma`` (m, c) through slot filters ``f``, ``g``:
    ``sum_l sigma_l^2 sum_q (f^T u_q)_l (g^T u_q)_l``, (c,)."""
    hu = f(U, reverse=True)
    gu = hu if g == f else g(U, reverse=True)
    return np.einsum("lq,lq->l", hu, gu) @ sigma**2


def fit(st: Steps, mt: np.ndarray) -> np.ndarray:
    """The offsets ``c`` (n,) of one record at ``Mt`` (4 n, n): least squares
    of the removed part of its equations ``U^T X Mt`` (q, n) on the offsets'
    patterns ``U^T Psi_j``."""
    n = mt.shape[1]
    A = st.signature()  # (n_f, 4 n)
    uf = st.U.T @ st.functions  # (q, n_f)
    live = np.flatnonzero(st.of >= 0)
    dof = live % n
    pattern = np.zeros((st.U.shape[1], n, n))  # (q, row, offset)
    for c, j in zip(live, dof):
        pattern[:, :, j] += np.outer(uf @ A[:, c], mt[c])
    return np.linalg.lstsq(pattern.reshape(-1, n), (st.removed @ mt).ravel(), rcond=None)[0]


def fixed_force(st: Steps, mt: np.ndarray, c: np.ndarray) -> np.ndarray:
    """The ``phi_(e+1)`` part of the offsets ``c`` (n,) in the equations at
    ``Mt`` (4 n, n), projected, (m, n): added to the force slot (which enters with -1)."""
    n = mt.shape[1]
    live = np.flatnonzero(st.of >= 0)
    on = live[st.d[st.of[live]] == st.fixed_d]
    return np.outer(st.fixed, c[on % n] @ mt[on])


def anderson(xs: list[np.ndarray], gs: list[np.ndarray], x: np.ndarray, g: np.ndarray) -> np.ndarray:
    """The next iterate of the fixed point ``x = G(x)`` by Anderson mixing of
    the last :data:`MEMORY` pairs (``xs``, ``gs`` extended in place; scaled
    so that the components are comparable): ``g - dG gamma``,
    ``gamma = argmin |f - dF gamma|``, ``f = g - x``."""
    xs.append(x)
    gs.append(g)
    del xs[:-MEMORY - 1], gs[:-MEMORY - 1]
    if len(xs) < 2:
        return g
    f = np.array(gs) - np.array(xs)
    dF, dG = np.diff(f, axis=0).T, np.diff(np.array(gs), axis=0).T
    gamma = np.linalg.lstsq(dF, f[-1], rcond=None)[0]
    return g - dG @ gamma
