"""Weighted FRF residuals of an affine model and their analytic Jacobian.

Model FRF of line ``l`` (frequency ``w``, force DOF ``f``) at the measured
response DOF ``s`` (receptance, then the measured quantity and the force's
hold)::

    Z(w) = K (1 + i eta) - w^2 M + i w C,   x = Z^-1 e_f,   H_s = x[s]
    h_l = (i w)^order  hold(w)  H_s,        hold(w) = (1 - e^(-i w h)) / (i w h)

``hold`` is the zero-order hold of a force held over ``h`` s (virtual tests,
docs/trace-format.md; 1 for ``h = 0``); its images at ``w + 2 pi k / h``,
which alias onto the samples, are neglected (relative ``(w h / 2 pi)^2``:
4e-5 at 5 rad/s on the chapter 4 cantilevers). ``C`` is the prior's damping
matrix (element and Rayleigh damping at the prior's values), never updated;
``eta`` is 0 except in the continuation below.

Residuals per line: ``d = h_l(alpha) - H_meas`` (m complex) as the real vector
``z = [Re d; Im d]`` (2m,), whitened ``r = L_l^-1 z`` by the Cholesky factor of
its covariance ``C_l = diag(std^2, std^2) + gain^2 v v^T + phase^2 u u^T``,
``v = [Re H; Im H]``, ``u = [-Im H; Re H]``: the per-entry errors plus the
errors common to a line (the force's amplitude and phase: one actuator
error moves every response of that line together). Real and imaginary
parts rather than log-magnitude and phase: the residual is linear in ``H``
(the Jacobian is exact, the noise of a line fit Gaussian with the stated
covariance, and no estimate is biased at low signal-to-noise), and an
undamped structure's FRF crosses zero (antiresonances) and changes sign at
resonances, where log-magnitude and phase are singular or jump by pi.
Entries with a NaN standard error are left out.

Jacobian (``alpha_j`` the scale factor of parameter ``p_j = p0_j (1 + alpha_j)``,
``D_j = p0_j dM_j/dp_j`` or ``dK_j/dp_j``)::

    dH_s/dalpha_j = -(Z^-1)[s, :] dZ_j x = -Y^T (dZ_j x),   Y = Z^-1 E_s

(``Z`` complex symmetric, so ``Z^-1[s, :] = (Z^-1 E_s)^T``), ``dZ_j = (1 + i eta) D_j``
(stiffness) or ``-w^2 D_j`` (mass): one factorisation per line and ``m + 1``
right-hand sides, dense LAPACK up to :data:`~.sensitivity.DENSE_LIMIT` DOF and a
sparse LU above. Unmeasured DOF need nothing: the model FRF is evaluated at
the measured (response, force) pairs only, no expansion or condensation.

Search, damping and the resonances of an undamped prior. ``Z`` is singular
where a line meets a resonance of an undamped model, and a search whose
iterate moves a model resonance across a measured line meets an infinite
residual there (a barrier: the trust region refuses the step). Far from the
answer the whitened real/imaginary misfit has a second trap: a model whose
FRF is small everywhere (mass and stiffness scaled up together) leaves the
residual at about ``-H_meas``, a local minimum the search from a prior 10 to
30 % off falls into (measured on the chapter 4 cantilevers). The searches
from each start therefore fit ``form="log"`` residuals first,
``log|h| - log|H_meas|`` with unit weights (a relative misfit that a
vanishing model FRF does not reduce), with a fictitious loss factor ``eta``
on the model (0.1, 0.03, 0.01, 0.003: the peaks broadened so that a
resonance slides over a line with a finite misfit; undamped priors only),
each stage from the last answer, then ``eta = 0``; the polish, the weight
and everything reported use the whitened real/imaginary residuals at
``eta = 0``. Natural frequencies (a lab's modal data given with
``data=both``, else those of the free vibration in the harmonic records,
:func:`structbench.identifier.updating._natural`) join every search stage
as eigenvalue residuals: they place the model's resonances, and without
them 7 of 20 searches on the chapter 4 case 1 records ended in a wrong
basin (normalized RMS 0.47 to 1.93). A line within 0.1 % of a resonance of an undamped prior is
left out (``details.frf.excluded``). A damped prior (element or Rayleigh
damping) has no such singularity and skips the loss factor; its damping
stays at the prior's values (damping parameters are not updated).

Why FRFs fix what modal data cannot: the force is measured (or commanded),
so ``H`` has absolute units; scaling ``M`` and ``K`` together by ``c``
scales ``H`` by ``1 / c``, which unscaled mode shapes and eigenvalues do not
see.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from .frf_data import FrfData
from .sensitivity import AffineModel

ETAS = (0.1, 0.03, 0.01, 0.003)  # loss factors of the continuation of an undamped prior's search
RESONANCE_BAND = 1e-3            # lines within this relative distance of a prior resonance are left out


@dataclass
class FrfEvaluation:
    """Whitened residuals ``r`` (n,), Jacobian ``J`` (n, q), the model FRF ``h`` (m, L)."""

    r: np.ndarray
    J: np.ndarray
    h: np.ndarray


def hold_factor(w: np.ndarray, h: np.ndarray) -> np.ndarray:
    """``(1 - e^(-i w h)) / (i w h)`` (1 where ``h = 0``)."""
    wh = np.asarray(w, dtype=float) * np.asarray(h, dtype=float)
    safe = np.where(wh == 0, 1.0, wh)
    return np.where(wh == 0, 1.0 + 0j, (1 - np.exp(-1j * safe)) / (1j * safe))


class FrfResiduals:
    """Residual function of the FRF ``data`` for ``model`` (module docstring);
    ``damping``: the prior's damping matrix (n, n) or None; ``eta``: the
    loss factor of the model (0: the model as it is)."""

    n_scales = 0

    def __init__(self, model: AffineModel, data: FrfData, force_index: np.ndarray, damping=None,
                 eta: float = 0.0, keep: np.ndarray | None = None, form: str = "complex") -> None:
        self.model, self.data, self.eta, self.form = model, data, float(eta), form
        self.force_index = np.asarray(force_index, dtype=int)
        self.damping = damping
        self.keep = np.ones(data.lines, bool) if keep is None else np.asarray(keep, bool)
        self.valid = np.isfinite(data.std) & (data.std > 0) & np.isfinite(data.H) & self.keep[None, :]
        self.factor = (1j * data.omega[None, :]) ** data.order[:, None] * hold_factor(data.omega, data.hold)[None, :]
        self._whiteners = [self._whitener(l) for l in range(data.lines)]
        self.n_res = int((2 if form == "complex" else 1) * self.valid.sum())
        self._cache: tuple[bytes, FrfEvaluation] | None = None

    def with_eta(self, eta: float, form: str = "complex") -> "FrfResiduals":
        """The same data with the model's loss factor ``eta`` and residual ``form``
        (``complex``: whitened real and imaginary parts; ``log``: ``log|h| - log|H|``, unit weights)."""
        return FrfResiduals(self.model, self.data, self.force_index, self.damping, eta, self.keep, form)

    @property
    def stated(self) -> dict[str, bool]:
        return {"frf": True}

    def _whitener(self, l: int) -> np.ndarray | None:
        rows = self.valid[:, l]
        if not rows.any():
            return None
        H, s = self.data.H[rows, l], self.data.std[rows, l]
        v = np.concatenate([H.real, H.imag])
        u = np.concatenate([-H.imag, H.real])
        C = np.diag(np.concatenate([s, s]) ** 2) + self.data.gain[l] ** 2 * np.outer(v, v) \
            + self.data.phase[l] ** 2 * np.outer(u, u)
        return la.solve_triangular(la.cholesky(C, lower=True), np.eye(v.size), lower=True)

    def leverage_of_scales(self, ev: FrfEvaluation) -> np.ndarray:
        return np.zeros(self.n_res)

    def _solve(self, M, K, w: float, rhs: np.ndarray) -> np.ndarray:
        model = self.model
        Z = (1 + 1j * self.eta) * K - w**2 * M
        if self.damping is not None:
            Z = Z + 1j * w * self.damping
        if model.dense:
            with np.errstate(all="ignore"):
                try:
                    return la.solve(Z, rhs.toarray() if sp.issparse(rhs) else rhs, check_finite=False)
                except la.LinAlgError:
                    return np.full(rhs.shape, np.inf, dtype=complex)
        try:
            return sla.splu(sp.csc_matrix(Z, dtype=complex)).solve(np.asarray(rhs, dtype=complex))
        except RuntimeError:  # exactly singular
            return np.full(rhs.shape, np.inf, dtype=complex)

    def model_frf(self, alpha: np.ndarray) -> np.ndarray:
        """The model FRF ``h`` (m, L) at the measured pairs (module docstring)."""
        return self(alpha).h

    def __call__(self, alpha: np.ndarray) -> FrfEvaluation:
        key = np.asarray(alpha, dtype=float).tobytes()
        if self._cache is not None and self._cache[0] == key:
            return self._cache[1]
        model, data = self.model, self.data
        M, K = model.matrices(alpha)
        n, m, q = model.n, len(data.dofs), model.q
        sensors = model.sensors
        E = np.zeros((n, m + 1), dtype=complex)
        E[sensors, np.arange(m)] = 1.0
        r, J = np.empty(self.n_res), np.empty((self.n_res, q))
        h = np.full((m, data.lines), np.nan, dtype=complex)
        row = 0
        for l in range(data.lines):
            w = data.omega[l]
            E[:, m] = 0.0
            E[self.force_index[l], m] = 1.0
            X = self._solve(M, K, w, E)
            x, Y = X[:, m], X[:, :m]
            h[:, l] = self.factor[:, l] * x[sensors]
            rows = self.valid[:, l]
            k = int(rows.sum())
            size = k * (2 if self.form == "complex" else 1)
            if k == 0:
                continue
            if not np.all(np.isfinite(x)):
                r[row:row + size] = np.inf
                J[row:row + size] = 0.0
                row += size
                continue
            G = np.zeros((n, q), dtype=complex)
            np.add.at(G, (model._d_rows, model._d_pos), model._d_vals * x[model._d_cols])  # D_j x
            G *= np.where(model.is_mass, -w**2, 1 + 1j * self.eta)[None, :]
            dH = -(Y[:, rows].T @ G) * self.factor[rows, l][:, None]  # (k, q)
            if self.form == "log":
                hl = h[rows, l]
                r[row:row + k] = np.log(np.abs(hl)) - np.log(np.abs(data.H[rows, l]))
                J[row:row + k] = (dH / hl[:, None]).real
                row += k
                continue
            d = h[rows, l] - data.H[rows, l]
            W = self._whiteners[l]
            r[row:row + 2 * k] = W @ np.concatenate([d.real, d.imag])
            J[row:row + 2 * k] = W @ np.vstack([dH.real, dH.imag])
            row += 2 * k
        out = FrfEvaluation(r, J, h)
        self._cache = (key, out)
        return out


class Combined:
    """Modal and FRF residuals stacked: ``r = [r_modal; r_frf]``, each weighted
    by its own stated errors; the modal part's pairing and shape scales as
    in :class:`.residuals.Residuals`."""

    def __init__(self, modal, frf: FrfResiduals) -> None:
        self.modal, self.frf = modal, frf
        self.n_res = modal.n_res + frf.n_res
        self.n_scales = modal.n_scales
        self.switches = 0

    @property
    def stated(self) -> dict[str, bool]:
        return self.modal.stated | self.frf.stated

    def __call__(self, alpha: np.ndarray) -> FrfEvaluation:
        a, b = self.modal(alpha), self.frf(alpha)
        self.last_modal = a
        return FrfEvaluation(np.concatenate([a.r, b.r]), np.vstack([a.J, b.J]), b.h)

    def leverage_of_scales(self, ev) -> np.ndarray:
        """The modal part's (of the last evaluation), 0 on the FRF rows."""
        return np.concatenate([self.modal.leverage_of_scales(self.last_modal), np.zeros(self.frf.n_res)])


def resonant_lines(model: AffineModel, data: FrfData, damped: bool, band: float = RESONANCE_BAND) -> np.ndarray:
    """Lines (L,) bool to keep: all for a damped prior; for an undamped one,
    those farther than ``band`` (relative) from every natural frequency of the prior."""
    if damped:
        return np.ones(data.lines, bool)
    M, K = model.matrices(np.zeros(model.q))
    count = min(model.n, 2 * data.lines + 10)
    lam, _ = model.modes(M, K, count)
    w = np.sqrt(np.clip(lam, 0.0, None))
    near = np.abs(data.omega[:, None] / np.where(w > 0, w, np.inf)[None, :] - 1.0) < band
    return ~near.any(axis=1)
