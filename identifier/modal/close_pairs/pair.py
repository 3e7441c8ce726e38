"""First-order view of a close pair of modes in free-decay records.

Two poles ``lambda_a,b = lambda + Delta_a,b`` with ``|Delta| T << 1`` over the
record length ``T`` give, record ``r``,

    c_ra e^(lambda_a t) + c_rb e^(lambda_b t) ~ (c_r + d_r t) e^(lambda t),
    c_r = phi_a p_ra + phi_b p_rb,    d_r = Delta_a phi_a p_ra + Delta_b phi_b p_rb,

with shapes ``phi`` and participations ``p`` (residues of rank one across
records). One pole with residues ``c_r`` and a ``t e^(lambda t)`` term with
residues ``d_r`` is linear least squares (:func:`first_order`). Three facts follow:

- a single pole leaves ``d_r`` that a shift of the pole (``d_r ~ Delta c_r``)
  cannot explain: :func:`score_statistics`, a score test on the residual;
- the records tell the two modes apart only if they move them in different
  proportions: ``C = [c_1 ... c_R] = Phi P`` has rank two
  (:func:`rank_one_misfit`: the weighted misfit of the best rank-one ``C``);
- then ``D = Phi diag(Delta_a, Delta_b) P`` and the eigenvalues of ``D^+ C``
  (in the leading two-dimensional record space) are ``1 / Delta_a,b``
  (:func:`pencil`): a start for the exact two-mode fit.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as la

from .free_decay_fit import ROTATE, Group, Projection, basis
from .rank_one_fit import Layout


@dataclass(frozen=True)
class FirstOrder:
    """Residues (m, R) complex in the channels' units of the pole (``c``)
    and of its ``t e^(lambda t)`` term (``d``); the covariance (R, 2, 2) of
    ``(Re c, Im c)`` per record for unit noise, and the noise levels ``scale`` (m, R)."""

    c: np.ndarray
    d: np.ndarray
    cov: np.ndarray
    scale: np.ndarray


def score_statistics(groups: list[Group], projections: list[Projection], poles: np.ndarray, tested: int
                     ) -> tuple[np.ndarray, int]:
    """The score statistic ``S`` (tested,) of each of the first ``tested`` poles
    for an unmodelled ``t e^(lambda t)`` term and its degrees of freedom
    ``2M - 2``. With ``F = (I - QQ^T) t [u_j, v_j]`` (n x 2), ``G = F^T F = L L^T``
    and the residual ``R`` (n x M) of the weighted group (``projections`` on ``poles``), ``h = vec(L^-1 F^T R)``
    (2M) is standard normal for a single pole; the two directions
    ``vec(L^T C_j)``, ``vec(L^T ROTATE C_j)`` that an error of the pole itself
    gives are projected out: ``S ~ chi^2(2M - 2)``. A pole whose ``t e^(lambda t)``
    lies in the basis (another pole there) gets 0."""
    h: list[list[np.ndarray]] = [[] for _ in range(tested)]
    w: list[list[np.ndarray]] = [[] for _ in range(tested)]
    for g, proj in zip(groups, projections):
        cols = basis(g.t, poles)[:, 2:].reshape(g.t.size, poles.size, 2) * g.t[:, None, None]
        for j in range(tested):
            f = cols[:, j] - proj.q @ (proj.q.T @ cols[:, j])
            gram = f.T @ f
            if not np.all(np.linalg.eigvalsh(gram) > 1e-12 * np.sum(cols[:, j] ** 2)):
                continue  # t e^(lambda t) lies in the basis: another pole sits here
            low = la.cholesky(gram, lower=True)
            cj = proj.coef[2 + 2 * j:4 + 2 * j]
            h[j].append(la.solve_triangular(low, cols[:, j].T @ proj.resid, lower=True).ravel())
            w[j].append(np.column_stack([(low.T @ cj).ravel(), (low.T @ ROTATE @ cj).ravel()]))
    stats = np.zeros(tested)
    for j in range(tested):
        if h[j]:
            hj, qw = np.concatenate(h[j]), la.qr(np.vstack(w[j]), mode="economic")[0]
            stats[j] = hj @ hj - np.sum((qw.T @ hj) ** 2)
    return stats, 2 * sum(g.z.shape[1] for g in groups) - 2


def first_order(groups: list[Group], layouts: list[Layout], poles: np.ndarray, j: int) -> FirstOrder:
    """Pole ``j`` with a ``t e^(lambda t)`` term, the other poles as they are."""
    m = layouts[0].scale.shape[1]
    records = sum(lay.records.size for lay in layouts)
    c, d = np.zeros((m, records), complex), np.zeros((m, records), complex)
    cov, scale = np.zeros((records, 2, 2)), np.zeros((m, records))
    flip = np.diag([1.0, -1.0])  # (Re c, Im c) = (a_u, -a_v)
    for g, lay in zip(groups, layouts):
        b = basis(g.t, poles)
        b = np.column_stack([b, g.t[:, None] * b[:, 2 + 2 * j:4 + 2 * j]])
        q, u = la.qr(b, mode="economic")
        coef = la.solve_triangular(u, q.T @ g.z)
        rows = la.solve_triangular(u, np.eye(u.shape[0])[:, 2 + 2 * j:4 + 2 * j], trans="T")  # rows of U^-1
        s = lay.scale.ravel()
        c[:, lay.records] = ((coef[2 + 2 * j] - 1j * coef[3 + 2 * j]) * s).reshape(-1, m).T
        d[:, lay.records] = ((coef[-2] - 1j * coef[-1]) * s).reshape(-1, m).T
        cov[lay.records] = flip @ rows.T @ rows @ flip  # block of (B^T B)^-1 = U^-1 U^-T
        scale[:, lay.records] = lay.scale.T
    return FirstOrder(c, d, cov, scale)


def _times(z: np.ndarray) -> np.ndarray:
    """(..., 2, 2) real matrices of multiplication by the complex ``z``: ``[[Re, -Im], [Im, Re]]``."""
    return np.stack([np.stack([z.real, -z.imag], -1), np.stack([z.imag, z.real], -1)], -2)


def rank_one_misfit(fo: FirstOrder, iterations: int = 50) -> tuple[float, int]:
    """The whitened misfit ``sum_ri |L_r^-1 (c_ri - phi_i p_r)|^2 / s_ri^2`` of
    the best rank-one ``phi p^T`` (alternating least squares; ``L_r L_r^T`` the
    covariance of ``(Re c, Im c)``) and its degrees of freedom ``2 (m - 1)(R - 1)``:
    chi^2 when the records move the mode(s) in one proportion."""
    m, records = fo.c.shape
    white = np.linalg.inv(np.linalg.cholesky(fo.cov))[None] / fo.scale[:, :, None, None]  # (m, R, 2, 2)
    x = np.einsum("irab,irb->ira", white, np.stack([fo.c.real, fo.c.imag], -1))
    u, sv, vh = la.svd(fo.c, full_matrices=False)
    phi, p = u[:, 0] * sv[0], vh[0]

    def solve(a: np.ndarray, axis: int) -> np.ndarray:
        """Least squares of ``x ~ a y`` summed over ``axis`` (a: (m, R, 2, 2))."""
        lhs = np.einsum("irab,irac->irbc", a, a).sum(axis)
        rhs = np.einsum("irab,ira->irb", a, x).sum(axis)
        y = np.linalg.solve(lhs, rhs[..., None])[..., 0]
        return y[..., 0] + 1j * y[..., 1]

    for _ in range(iterations):
        phi = solve(white @ _times(p)[None], 1)
        p = solve(white @ _times(phi)[:, None], 0)
    fitted = np.einsum("irab,irb->ira", white @ _times(p)[None], np.stack([phi.real, phi.imag], -1)[:, None])
    return float(np.sum((x - fitted) ** 2)), 2 * (m - 1) * (records - 1)


def pencil(fo: FirstOrder, pole: complex) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Participations (1, R) of the pole as one mode (leading singular vector
    of ``C``), and the pair's poles (2,) and participations (2, R) from the
    eigenvalues ``1 / Delta`` of ``D^+ C`` (non-finite when ``D`` vanishes)."""
    c, d = fo.c, fo.d
    u, sv, vh = la.svd(c, full_matrices=False)
    single = (sv[0] * vh[0])[None, :]
    vr = la.svd(np.vstack([c, d]), full_matrices=False)[2][:2].conj().T  # (R, 2)
    nu, beta = la.eig(la.pinv(d @ vr) @ (c @ vr))
    with np.errstate(divide="ignore", invalid="ignore"):
        return single, pole + 1.0 / nu, la.pinv(c @ vr @ beta) @ c
