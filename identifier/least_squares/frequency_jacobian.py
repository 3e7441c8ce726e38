"""Output-error residuals, their Jacobian and the Gauss-Newton normal
equations for :mod:`identifier.least_squares.frequency_output`, computed
from the sparsity of the parameters' derivatives.

At a line ``omega`` (rad/s) and force DOF ``f``, with ``Z = K - omega^2 M +
i omega C`` (n x n), ``Hh = Z^-1`` and the model's receptance column ``hh =
Hh e_f``, the whitened output error and the derivative of the whitened
model output with respect to an unknown parameter ``p_j`` are

    r = (h - hh) / sd,    J_j = d (hh / sd) / d p_j = -Hh Z_j hh / sd,

(``sd = sqrt(V + 1e-9 mean(V))``: the line variances ``V`` floored) with
``Z_j = dZ / dp_j = K_j - omega^2 M_j + i omega C_j``. ``Z_j hh`` is column
``j`` of the regression of :class:`~.frequency.Equations` at ``u = hh``; a
parameter's matrices touch only its element's DOF, so ``y_j = Z_j hh`` has
``rmax`` nonzero rows ``R_j`` (4 for a beam element) made of ``imax``
entries ``hh[I_j]``:

    y_j[s] = sum_t (-omega^2 Q_a + i omega Q_v + Q_u)[j, s, t] hh[I_j[t]],
    J_j = -Hh[:, R_j] y_j / sd,

``Q`` the layout's channel weights (Rayleigh factors included). This costs
``n rmax`` per parameter and line instead of the ``n^2`` of ``Hh Y``; the
inverse ``Hh`` (``n^3``) is then the largest cost. Padded slots carry ``Q =
0``. Where ``n`` is at most :data:`DENSE_RATIO` times ``rmax`` the ``y_j``
are scattered into a dense ``Y`` and ``Hh Y`` taken as one small matrix
product per line instead (more arithmetic, but at BLAS speed).

Only the real part of the complex normal equations is needed:

    A = Re(J^H J) = sum_b Jv_b Jv_b^T,   g = Re(J^H r) = sum_b Jv_b rv_b,

with ``Jv_b`` the (n_u, 2 n) real view of block ``b``'s ``J`` (real and
imaginary parts interleaved) and ``rv_b`` that of ``r_b``: real products, no
conjugated copy, and one small product per block (a single product over all
blocks is as much arithmetic, but a threaded BLAS call: on a loaded machine
its threads wait for each other).

Shapes: ``B`` blocks (line x force), ``n`` DOF, ``n_u`` unknowns. Fails (a
``LinAlgError`` from ``inv``) only where ``Z`` is exactly singular at a line;
non-finite values propagate (the caller rejects such a step).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .frequency import CHUNK, Equations, Lines, matrices

DENSE_RATIO = 8  # J by one dense product per line when n <= DENSE_RATIO x (rows per parameter), else gathered


class Derivatives:
    """The compact ``Z_j`` of the unknown columns ``u`` (module docstring):
    rows ``R`` (n_u, rmax), inputs ``I`` (n_u, imax) and weights ``Q`` (3,
    n_u, rmax, imax) for the acceleration, velocity and displacement terms."""

    def __init__(self, eq: Equations, u: np.ndarray):
        n, lay = eq.n, eq.lay
        per = []
        for j in u:
            pairs = np.flatnonzero(lay.pair_col == j)
            rows = np.unique(lay.pair_row[pairs])
            used = np.flatnonzero(np.any(eq.Wd[:3 * n, pairs] != 0, axis=1)) % n
            per.append((pairs, rows, np.unique(used)))
        rmax = max([1] + [r.size for _, r, _ in per])
        imax = max([1] + [i.size for _, _, i in per])
        self.rows = np.arange(u.size)
        # the dense product does n / rmax times the arithmetic of the gather, at several times its speed
        self.dense = eq.n <= DENSE_RATIO * rmax
        self.R = np.zeros((u.size, rmax), dtype=int)
        self.I = np.zeros((u.size, imax), dtype=int)
        self.Q = np.zeros((3, u.size, rmax, imax))
        for j, (pairs, rows, inputs) in enumerate(per):
            self.R[j, :rows.size], self.I[j, :inputs.size] = rows, inputs
            for pair in pairs:
                s = np.searchsorted(rows, lay.pair_row[pair])
                for k in range(3):
                    self.Q[k, j, s, :inputs.size] += eq.Wd[k * n + inputs, pair]

    def columns(self, omega: np.ndarray, hh: np.ndarray) -> np.ndarray:
        """``y_j = Z_j hh`` at rows ``R_j``: (b, n_u, rmax) complex, from
        ``omega`` (b,) rad/s and ``hh`` (b, n)."""
        hI = hh[:, self.I]  # (b, n_u, imax)
        y = [np.einsum("jst,bjt->bjs", self.Q[k], hI) for k in range(3)]
        return -(omega**2)[:, None, None] * y[0] + 1j * omega[:, None, None] * y[1] + y[2]


@dataclass
class Evaluation:
    """The model at ``p`` (all parameters) over ``lines``: ``hh`` (B, n)
    receptance columns, ``J`` (B, n_u, n) the Jacobian of ``hh / sd``
    (``J[b, j]`` the derivative of block ``b`` by unknown ``j``), ``sd`` (B, n)
    the whitening, ``A = Re(J^H J)`` (n_u, n_u). Independent of the measured ``h``."""

    p: np.ndarray
    hh: np.ndarray
    J: np.ndarray
    sd: np.ndarray
    A: np.ndarray

    def residual(self, lines: Lines) -> np.ndarray:
        """``r = (h - hh) / sd`` (B, n) complex."""
        return (lines.h - self.hh) / self.sd

    def scores(self, r: np.ndarray) -> np.ndarray:
        """Per-block ``s_b = Re(J_b^H r_b)`` (B, n_u): real views, one small product per block."""
        B, n = r.shape
        return np.matmul(self.J.view(float), r.view(float).reshape(B, 2 * n, 1))[..., 0]

    def normal(self, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``A = Re(J^H J)`` (n_u, n_u) and ``g = Re(J^H r) = sum_b s_b`` (n_u,)."""
        return self.A, self.scores(r).sum(axis=0)


def evaluate(eq: Equations, deriv: Derivatives, lines: Lines, p: np.ndarray) -> Evaluation:
    """:class:`Evaluation` at parameters ``p`` (module docstring), in chunks of lines."""
    M, C, K = (np.ascontiguousarray(a.T) for a in matrices(eq.model, p))  # Z^T: inv(Z^T) = Hh^T, row-major
    B, n = lines.h.shape
    n_u = deriv.R.shape[0]
    hh = np.empty((B, n), dtype=complex)
    J = np.empty((B, n_u, n), dtype=complex)
    A = np.zeros((n_u, n_u))
    scale = np.mean(lines.var)
    sd = np.sqrt(lines.var + 1e-9 * scale) if scale > 0 else np.ones_like(lines.var)
    for lo in range(0, B, CHUNK):
        part = slice(lo, lo + CHUNK)
        w, f = lines.omega[part], lines.force[part]
        Z = K[None] - (w**2)[:, None, None] * M[None] + 1j * w[:, None, None] * C[None]
        HT = np.linalg.inv(Z)  # Z holds Z^T: HT[b, c] is column c of Hh
        hh[part] = HT[np.arange(w.size), f]
        y = deriv.columns(w, hh[part])  # (b, n_u, rmax)
        HT /= -sd[part, None, :]
        if deriv.dense:  # y_j scattered into n rows: one small complex product per line
            Y = np.zeros((w.size, n_u, n), dtype=complex)
            for s in range(deriv.R.shape[1]):
                Y[:, deriv.rows, deriv.R[:, s]] += y[:, :, s]
            J[part] = np.matmul(Y, HT)
        else:  # the rmax rows of HT each parameter touches
            J[part] = HT[:, deriv.R[:, 0]] * y[:, :, 0, None]
            for s in range(1, deriv.R.shape[1]):
                J[part] += HT[:, deriv.R[:, s]] * y[:, :, s, None]
        Jv = J[part].view(float)  # (b, n_u, 2 n): Re(J_b^H J_b) = Jv_b Jv_b^T
        A += np.matmul(Jv, Jv.transpose(0, 2, 1)).sum(axis=0)
    return Evaluation(np.array(p, dtype=float), hh, J, sd, A)
