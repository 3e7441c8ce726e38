"""Standard errors of SSI-cov frequencies and damping ratios by the
delete-one-group jackknife.

The covariance sums are kept per sample group (``G`` groups,
:mod:`identifier.modal.ssi.covariance`); replicate ``g`` repeats the identification
from every group but ``g``. Its subspace is one step of subspace iteration
from the full data's leading left singular vectors ``U``: ``Q_g = H_g H_g^T
U R^-1`` with ``R`` upper triangular (see :class:`Replicates`), so that its first
``n`` columns span the replicate's subspace of order ``n``; two Hankel
products by FFT (:mod:`identifier.modal.ssi.hankel`, the FFT of ``U`` shared) and a
triangular solve per replicate, two replicates at a time, in the background
(:class:`Replicates`). (The cheaper first-order subspace
``U + (I - U U^T) E_g V S^-1`` fails for free decays: a mode that one group
holds almost alone loses nearly all of its singular value when that group
is left out, far outside first order, and the errors came out 2-4 times too
small.) At order ``n`` the basis ``Q_n T^-1``, ``T = U_n^T Q_n``, is the one
nearest ``U_n``; its ``M_g = T G_g^-1 K_g T^-1`` (:mod:`identifier.modal.ssi.poles`)
is near the full data's ``M = Psi diag(mu) Psi^-1``, and with ``W = Psi^-1
(M_g - M) Psi`` each pole ``k`` of a mode moves, to first order, to

    mu_k + W_kk,     psi_k + sum_(i != k) psi_i W_ik / (mu_k - mu_i)

(no eigen-decomposition per replicate); a pole that mixes strongly with a
near one (``|W_ik| > 0.3 |mu_k - mu_i|``, Im ``mu_i`` > 0) is followed through the
eigenvectors of that small group instead. A mode is found again at an order
when its pole stays within 5 % of the mode's frequency with MAC > 0.8 to the
full data's shape; the replicate takes the medians over the mode's stable
poles at a few orders (eight spread over all the modes' orders and shared
by them, so that the tracking runs at eight orders, or eight of the mode's
own when it is stable at fewer than three of those; chosen in
:mod:`identifier.modal`), when it is found at at least half of them. With ``theta_g``
the replicates and ``theta_.`` their mean,

    se^2 = (G - 1) / G sum_g (theta_g - theta_.)^2     (Quenouille-Tukey),

stated times ``t_0.975(G - 1) / z_0.975`` (1.20 for ``G = 8``): the
estimate has ``G - 1`` degrees of freedom, and the stated error is read
as normal (``+- 1.96 se`` for 95 %), so it carries Student's quantile.

Assumes the groups' noise contributions are nearly independent: contiguous
segments longer than the response's correlation time (stationary records) or
interleaved blocks of half the lag span (free decay; shorter blocks share
too many lagged samples between groups and the errors come out too small).
Noise modes move far (small gaps between poles) and are not found again.
With few groups the estimate has ``G - 1`` degrees of freedom; a mode not
found in some replicates gets the same formula over the ``G'`` replicates
that found it (``G'`` for ``G``; NaN when ``G' < 2``): in a free decay a
mode that has died out within the first block of samples is seen by one
group only. A mode whose correlation time exceeds the stationary segments (the
damped beam's first mode, 507 s, in 450 s segments) gets errors somewhat
too small.

Mode shapes (:func:`shape_deltas`). A replicate's shape of a pole,
``z_g`` (the first-order shape above, in the channels' units), is scaled
to the full data's ``z`` of the same pole by complex least squares,
``c_g = z_g^H z / z_g^H z_g``, and expressed in the reported normalisation
(:func:`identifier.modal.ssi.poles.real_shapes`: the full shape turned by
its principal angle ``theta``, real part, divided by its largest entry
``peak``):

    d_g = Re((c_g z_g - z) e^(-i theta)) / peak      (m,)

per entry, the median over the mode's poles like omega, then the same
jackknife formula entry by entry: the standard error of each entry of the
reported shape with its scale fitted (an error along the shape itself, a
change of scale, is left out: updating profiles the scale out, and the
largest entry's error is not zero). Only where the Hankel's row channels
are the channels (at most ``ROW_CHANNELS`` sensors); NaN otherwise.

The reported shape is one pole's, at one model order, and the jackknife
measures each order's noise about that order's own estimate, not how far
the orders disagree; for the higher modes of a random response these
differ by several jackknife errors. So the stated error adds, in
quadrature, the shape's robust scatter over the mode's stable poles
(:func:`order_spread`, ``s_l``: 1.4826 times the median absolute deviation,
robust to the poles that split one mode at high orders), like omega's
error adds the scatter of the poles' frequencies:

    std_l^2 = se_l^2 + s_l^2.

The reported pole can be one of those split poles: when its distance from
the poles' median shape (``r_l``) stands out of these errors, ``sum_l
r_l^2 / std_l^2 > chi^2_(0.99)(m - 1)``, it is added in quadrature. And
when the part of the shapes out of phase with the reported real shape
(``o_l``, the median over the poles) stands out of the errors so far by
the same test, it is added too: a real (normal-mode) shape leaves it out, so it is an
error of the reported shape whenever the structure's modes are real
(proportional damping, which the updating's FE shapes are), and otherwise
a sign that another pole (an unmodelled or aliased mode) leaks into this
one. Below the test it is noise, which the jackknife already carries.
Fails (understates) when every order is biased alike and the shapes stay
real: a mode near the top of the band whose neighbours above are out of
the model at every order.
"""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import scipy.linalg as la
from scipy.linalg.blas import dsyrk, dtrsm
from scipy.stats import chi2, t as student_t

from structbench.models.mac import paired_mac

from .ssi.covariance import Covariances, project
from .ssi.hankel import BlockHankel
from .ssi.poles import Poles

STANDS_OUT = 0.999  # chi^2 quantile past which the reported pole's distance or the out-of-phase part is an error
Target = tuple[tuple[tuple[int, int], ...], float]  # the mode's stable poles (order, index), its omega rad/s


def _moved(space: tuple[np.ndarray, ...], U: np.ndarray, poles: Poles, picks: np.ndarray, dt: float
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """omega, zeta and MAC to the full data's shape (G, t) of the poles
    ``picks`` (indices into ``poles.omega``) of one order in every replicate
    (``space``: stacked Gram, shift, ``U^T Q`` and first block rows of the
    replicates' bases ``Q``), to first order from the full data's
    eigen-decomposition; shapes in the Hankel's row channels. A pole that
    mixes strongly with another of Im > 0 (``|W_ik| > 0.3 |mu_k - mu_i|``: a
    pair closer than the perturbation) is followed instead through the
    eigenvectors of that small group, ``diag(mu_b) + W_bb``: the one with the
    best MAC is the replicate's pole. Also the replicates' shapes (G, rows,
    t) and the full data's (rows, t), complex, in the row channels."""
    gram, shift, align, top = space
    n, rows = poles.order, top.shape[1]
    cols = poles.index[picks]
    psi, mu0 = poles.vectors[:, cols], poles.mu[cols]
    T = align[:, :n, :n]
    M = T @ np.linalg.solve(gram[:, :n, :n], shift[:, :n, :n] @ np.linalg.inv(T))  # (G, n, n): M_g
    inverse = np.linalg.inv(poles.vectors)  # rows: the left eigenvectors, chi_i^H psi_j = delta_ij
    W = inverse @ (M @ psi)
    own = (slice(None), cols, np.arange(cols.size))
    W[own] -= mu0
    mu = mu0 + W[own]
    gap = mu0[None, :] - poles.mu[:, None]
    gap[cols, np.arange(cols.size)] = np.inf
    mix = W / gap
    base = top[:, :, :n] @ np.linalg.solve(T, poles.vectors)  # (G, rows, n): replicate shapes of every psi_i
    shape = U[:rows, :n] @ psi
    moved = base[:, :, cols] + base @ mix
    mac = paired_mac(shape, moved)
    strong = (np.abs(mix) > 0.3) & (poles.mu.imag > 0)[None, :, None]
    for g, c in zip(*np.nonzero(strong.any(axis=1))):
        group = np.union1d(cols[c], np.flatnonzero(strong[g, :, c]))
        lam, y = np.linalg.eig(inverse[group] @ M[g] @ poles.vectors[:, group])
        fits = paired_mac(shape[:, [c]], base[g][:, group] @ y)
        best = int(np.argmax(fits))
        mu[g, c], mac[g, c] = lam[best], fits[best]
        moved[g, :, c] = (base[g][:, group] @ y)[:, best]
    s = np.log(mu) / dt
    return np.abs(s), -s.real / np.abs(s), mac, moved, shape


def shape_deltas(full: np.ndarray, moved: np.ndarray) -> np.ndarray:
    """``d_g`` (G, m, t) of the module docstring: the replicates' shapes
    ``moved`` (G, m, t) scaled to the full data's ``full`` (m, t) (complex,
    the channels' units) and expressed in the reported real normalisation."""
    c = np.einsum("gmt,mt->gt", moved.conj(), full) / np.maximum(np.einsum("gmt,gmt->gt", moved.conj(), moved).real,
                                                                  1e-300)
    re, im = full.real, full.imag
    theta = 0.5 * np.arctan2(2 * np.sum(re * im, 0), np.sum(re**2, 0) - np.sum(im**2, 0))
    turn = np.exp(-1j * theta)
    rotated = (full * turn).real
    peak = rotated[np.argmax(np.abs(rotated), axis=0), np.arange(full.shape[1])]
    return ((c[:, None, :] * moved - full) * turn).real / np.where(peak == 0, 1.0, peak)



class Replicates:
    """The replicates' bases, computed in the background from the moment the
    full data's ``U`` (p m, N) is known (two threads; FFT and BLAS release
    the GIL), while the caller finds the full data's poles and modes.

    Replicate ``g``'s basis is ``B = Y R^-1``, ``Y = H_g H_g^T U``, ``U^T Y =
    Q_z R`` (QR of the small N x N matrix): ``R`` is upper triangular, so the
    first ``n`` columns of ``B`` span those of ``Y`` for every order ``n``,
    and ``B = U Q_z + (I - U U^T) Y R^-1`` is near orthonormal (a Householder
    QR of ``Y``, which spans singular values over many decades, costs twice
    as much for the same poles)."""

    def __init__(self, cov: Covariances, W: np.ndarray | None, full: BlockHankel, U: np.ndarray):
        """``full``: the full data's Hankel operator (its sizes; its FFT of ``U`` serves every replicate)."""
        self.U, self.dt, self.groups = U, cov.dt, cov.sums.shape[0]
        self.channels = cov.scale.size
        self.scale = cov.scale if W is None else None  # channel RMS; None: row channels are projections
        blocks = (full.rows, full.columns)
        rows = U.shape[0] // full.rows
        Uf = full.transform(U, full.rows)

        def basis(g: int) -> tuple[np.ndarray, ...]:
            H = BlockHankel(project(cov.mean(leave_out=g), W), *blocks)
            Y = H @ H.rmatmul(U, Uf)
            Z = U.T @ Y
            R = la.qr(Z, mode="r")[0]
            B = dtrsm(1.0, R, Y.T, side=0, trans_a=1).T  # Y R^-1
            last = B[-rows:]
            gram = dsyrk(1.0, B.T, trans=0, lower=0)  # B^T B, upper triangle
            gram = np.triu(gram) + np.triu(gram, 1).T - last.T @ last
            return gram, B[:-rows].T @ B[rows:], dtrsm(1.0, R, Z, side=1), B[:rows]  # U^T B = Z R^-1

        pool = ThreadPoolExecutor(2)
        self._parts = [pool.submit(basis, g) for g in range(self.groups)]
        pool.shutdown(wait=False)

    def space(self) -> tuple[np.ndarray, ...]:
        """Stacked over the replicates: Gram ``B_up^T B_up``, shift ``B_up^T
        B_down``, ``U^T B`` (G, N, N) and first block rows (G, rows, N)."""
        return tuple(np.stack(x) for x in zip(*(part.result() for part in self._parts)))


def jackknife(replicates: Replicates, poles: dict[int, Poles], targets: list[Target]
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Standard errors (k,) of omega (rad/s) and zeta of the target modes
    (``poles``: the full data's poles by order) over the replicates that
    found each (NaN when fewer than two did); how many replicates missed
    each mode (k,); and the standard errors (m, k) of the entries of each
    mode's reported shape (module docstring; NaN where the row channels are
    projections or fewer than two replicates found the mode)."""
    space, U, groups = replicates.space(), replicates.U, replicates.groups
    scale, channels = replicates.scale, replicates.channels
    if not targets:
        return np.zeros(0), np.zeros(0), np.zeros(0, dtype=int), np.zeros((channels, 0))
    m = channels if scale is not None else 0
    found: list[list[list[tuple[float, float]]]] = [[[] for _ in targets] for _ in range(groups)]
    deltas: list[list[list[np.ndarray]]] = [[[] for _ in targets] for _ in range(groups)]
    for n in sorted({n for members, _ in targets for n, _ in members}):
        which = [(k, j) for k, (members, _) in enumerate(targets) for order, j in members if order == n]
        try:
            omega, zeta, mac, moved, full = _moved(space, U, poles[n], np.array([j for _, j in which]),
                                                   replicates.dt)
        except np.linalg.LinAlgError:  # a replicate's subspace lost a direction of this order: nothing found
            continue
        d = shape_deltas(full * scale[:, None], moved * scale[None, :, None]) if scale is not None else None
        w0 = np.array([targets[k][1] for k, _ in which])
        for g, c in zip(*np.nonzero((np.abs(omega - w0) < 0.05 * w0) & (mac > 0.8))):
            found[g][which[c][0]].append((omega[g, c], zeta[g, c]))
            if d is not None:
                deltas[g][which[c][0]].append(d[g, :, c])
    reps = np.full((groups, len(targets), 2 + m), np.nan)
    for g in range(groups):
        for k, (members, _) in enumerate(targets):
            if found[g][k] and 2 * len(found[g][k]) >= len(members):
                reps[g, k, :2] = np.median(found[g][k], axis=0)
                if m:
                    reps[g, k, 2:] = np.median(deltas[g][k], axis=0)
    found_by = np.isfinite(reps[:, :, :1])  # (G, k, 1)
    count = found_by.sum(axis=0)  # (k, 1): replicates that found each mode
    values = np.where(found_by, reps, 0.0)
    mean = values.sum(axis=0) / np.maximum(count, 1)
    spread = np.sum(np.where(found_by, (values - mean) ** 2, 0.0), axis=0)
    widen = student_t.ppf(0.975, np.maximum(count - 1, 1)) / student_t.ppf(0.975, np.inf)
    se = np.where(count >= 2, widen * np.sqrt((count - 1) / np.maximum(count, 1) * spread), np.nan)
    shape_se = np.full((channels, len(targets)), np.nan)
    if m:
        orders, reported, out_of_phase = order_spread(poles, targets)
        shape_se = np.hypot(se[:, 2:].T, orders)
        for part in (reported, out_of_phase):  # each where it stands out of the errors so far
            z = np.divide(part, shape_se, out=np.zeros_like(part), where=shape_se > 0)  # one channel: 0 / 0
            out = np.sum(z**2, axis=0) > chi2.ppf(STANDS_OUT, max(m - 1, 1))
            shape_se[:, out] = np.hypot(shape_se, part)[:, out]
    return se[:, 0], se[:, 1], groups - count[:, 0], shape_se


def order_spread(poles: dict[int, Poles], targets: list[Target]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What the replicates do not see of one pole's shape, per entry (m, k)
    of each target mode's reported normalisation (module docstring): with
    ``b_j`` the real shapes (:func:`identifier.modal.ssi.poles.real_shapes`)
    of the mode's stable poles ``j`` (its ``targets`` members; shapes in the
    channels' units, as the poles hold them) and ``b_r`` that of the
    reported pole (of all orders' poles the one nearest the mode's median
    omega, which is how :func:`identifier.modal.stabilisation.select_modes`
    picks it), each scaled by least squares to the members' entry-wise
    median ``b~``, the shape's robust scatter over the model orders, the
    reported pole's distance from the median and the median out-of-phase
    part,

        s_l = 1.4826 median_j |b_jl - b~_l|,   r_l = |b_rl - b~_l|,   o_l = median_j |Im_jl|,

    ``Im_j`` the imaginary part of pole ``j``'s complex shape turned by its
    principal angle, over its largest entry. The median absolute deviation
    is robust to the poles that split one mode at high orders; ``r``
    covers the reported pole when it is one of them. All zero for a mode of
    a single real pole."""
    out = np.zeros((next(iter(poles.values())).shapes.shape[0], len(targets)))
    quad, far = np.zeros_like(out), np.zeros_like(out)
    for k, (members, w) in enumerate(targets):
        nearest = [(abs(p.omega - w).min(), n, int(np.argmin(abs(p.omega - w)))) for n, p in poles.items()
                   if p.omega.size]
        _, n_r, j_r = min(nearest)
        z = np.column_stack([poles[n].shapes[:, j] for n, j in ((n_r, j_r), *members)])  # (m, 1 + t)
        re, im = z.real, z.imag
        theta = 0.5 * np.arctan2(2 * np.sum(re * im, 0), np.sum(re**2, 0) - np.sum(im**2, 0))
        turned = z * np.exp(-1j * theta)
        peak = turned.real[np.argmax(np.abs(turned.real), axis=0), np.arange(z.shape[1])]
        peak = np.where(peak == 0, 1.0, peak)
        b, out_of_phase = turned.real / peak, turned.imag[:, 1:] / peak[1:]
        centre = np.median(b[:, 1:], axis=1)
        b = b * (centre @ b / np.maximum(np.sum(b * b, axis=0), 1e-300))
        centre = np.median(b[:, 1:], axis=1)
        mad = 1.4826 * np.median(np.abs(b[:, 1:] - centre[:, None]), axis=1)
        out[:, k], far[:, k] = mad, np.abs(b[:, 0] - centre)
        quad[:, k] = np.median(np.abs(out_of_phase), axis=1)
    return out, far, quad


def carried(shape_se: np.ndarray, source: np.ndarray, refined: np.ndarray) -> np.ndarray:
    """The shape errors (m, k) of the modes after the close-pair split: mode
    ``i`` keeps those of input mode ``source[i]``; NaN where its shape comes
    from the free-decay fit (``refined``) or it was found there (``source`` -1)."""
    out = np.full((shape_se.shape[0], source.size), np.nan)
    keep = (source >= 0) & ~refined
    out[:, keep] = shape_se[:, source[keep]]
    return out

