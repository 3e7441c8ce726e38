"""Full (DOF-coupled) whitening of the regression, for models of up to :data:`DENSE_DOF` DOF.

The equation errors of one sample, ``e_k = M da + C dv + K du - df`` (n,),
are correlated across DOF rows through ``M``, ``C``, ``K``: their covariance is

    S = Mt^T diag(sigma^2) Mt,    Mt[c, r] = sum_j theta_j W[c, (r, j)]  (4 n, n)

(time-averaged channel noise ``sigma^2``). Weighting the equations of each
sample by ``Omega = S^-1`` (generalised least squares) instead of one weight
per row matters when the noisy channels enter through a matrix that mixes
rows, e.g. noisy displacements through ``K``. With ``B_k[r, j] = (W^T x_k)[(r, j)]``
for the raw channels ``x_k`` (4 n,):

    G = sum_k B_k^T Omega B_k = P^T ((W^T X^T X W) o Omega[row_p, row_q]) P
    D = E[noise part of G]    = P^T ((W^T diag(sum_k sigma_k^2) W) o Omega[row_p, row_q]) P

(``o``: element-wise product over the (row, column) pairs ``p``, ``q``; ``P``
maps pairs to columns). ``X^T X`` (4 n, 4 n) is accumulated in the pass of
:func:`identifier.least_squares.regression.moments`: time
O(m n^2), memory O(n^2), hence the DOF limit. The per-sample estimating
terms for the sandwich standard errors are

    g_k = B_k^T Omega e_k - sum_c sigma^2[c, k] (W_c^T o (Omega Mt^T)[row, c]).
"""
from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import scipy.sparse as sp

from .regression import Layout, chunks, raw, raw_variance


def equation_matrix(lay: Layout, theta: np.ndarray) -> np.ndarray:
    """``Mt`` (4 n, n): ``e_k = Mt^T x_k`` = M a + C v + K u - f at ``theta``."""
    to_row = sp.csr_matrix((theta[lay.pair_col], (np.arange(lay.pair_col.size), lay.pair_row)),
                           shape=(lay.pair_col.size, lay.n_dof))
    return np.asarray((lay.W @ to_row).todense())


def error_covariance(lay: Layout, noise_mean: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Covariance ``S`` (n, n) N^2 of one sample's equation errors at ``theta``."""
    mt = equation_matrix(lay, theta)
    return mt.T @ (noise_mean[:, None] * mt)


def gram(lay: Layout, xtx: np.ndarray, noise: np.ndarray, omega: np.ndarray) -> tuple[sp.csr_matrix, sp.csr_matrix]:
    """``G`` and ``D`` (n_columns, n_columns) for the weighting ``omega`` (n, n)."""
    P = lay.P
    Wc = lay.W.tocsc()
    coupling = omega[np.ix_(lay.pair_row, lay.pair_row)]
    signal = np.asarray((Wc.T @ (Wc.T @ xtx).T)) * coupling
    noisy = (Wc.T @ sp.diags(noise) @ Wc).multiply(coupling)
    return sp.csr_matrix(P.T @ signal @ P), sp.csr_matrix(P.T @ noisy @ P)


def scores(lay: Layout, motion, theta: np.ndarray, omega: np.ndarray) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """Per sample ``g_k`` (n_columns, m_chunk) and the equation errors ``e`` (n, m_chunk) N, chunk by chunk."""
    mt = equation_matrix(lay, theta)
    PT = lay.P.T.tocsr()
    w = lay.W.tocoo()
    coef = sp.csr_matrix((w.data * (omega @ mt.T)[lay.pair_row[w.col], w.row], (w.col, w.row)),
                         shape=(lay.pair_col.size, 4 * lay.n_dof))
    spread = (PT @ coef).tocsr()  # (n_columns, 4 n)
    Wt = lay.W.T.tocsr()
    for where in chunks(lay, motion.force.shape[0]):
        x = raw(motion, where)
        e = mt.T @ x
        y = Wt @ x  # (n_pairs, m_chunk)
        yield PT @ (y * (omega @ e)[lay.pair_row]) - spread @ raw_variance(motion, where), e
