"""Pole-residue fit of measured FRFs and the unit-modal-mass scaling of its residues.

Model (time dependence ``exp(+i omega t)``, docs of :mod:`identifier.frf`).
A linear structure ``M x'' + C x' + K x = f`` with modal poles
``lambda_r = -zeta_r omega_r + i omega_d,r`` (``omega_d = omega sqrt(1 -
zeta^2)``) has the displacement receptance

    H_ij(s) = sum_r R_r,ij / (s - lambda_r) + conj(R_r,ij) / (s - conj(lambda_r)),
    R_r,ij = psi_r,i psi_r,j / (2 i omega_d,r)  (proportional damping),

with ``psi_r`` the mode shape scaled to unit modal mass (``psi^T M psi =
1``); with a shape ``phi_r`` of modal mass ``m_r = phi^T M phi`` this is
``R = phi_i phi_j / (2 i omega_d m_r)``. A sensor of velocity or
acceleration multiplies by ``s`` or ``s^2``.

The traces hold the force constant over each sample (zero-order hold), so
the FRF estimated from them is that of the sampled system, ``z = exp(i omega
dt)``. Each pole's term is then exactly (displacement, ``p = exp(lambda dt)``)

    R (p - 1) / (lambda (z - p)),

and ``lambda^k`` times that for a sensor of the ``k``-th derivative (the
polynomial parts ``R s``, ``R lambda`` summed over all modes vanish or are
a constant the residual terms take). The coefficients fitted are therefore
the displacement residues ``R_r,i`` whatever each sensor measures. Modes
outside the band, and an acceleration's feedthrough, enter through real
residual terms per channel: ``1`` and ``z^-1`` (feedthrough; a mode far above
the band answers the force held over the last sample) and, times the hold's
factor ``(1 - exp(-i omega dt)) / (i omega dt)``, ``(i omega)^e`` for ``e``
in ``{k, k - 2}`` without 0 (the sensor's own, and mass-like: modes below).

Fit (:func:`fit`): weighted least squares of the residues (linear) for
given poles; :func:`refine` moves the poles too (variable projection: the
residues are eliminated, the poles' ``omega`` and ``zeta`` fitted by
Gauss-Newton). Weights ``1 / (|H| eps)`` with ``eps`` the FRF's normalized
random error from its coherence (floored at ``EPS_FLOOR``): lines of low
coherence count little.

Scaling (:func:`scale`): from the driving-point residue (the response
collocated with the force, index ``j``) ``psi_j^2 = 2 i omega_d R_jj``, then
``psi_i = 2 i omega_d R_ij / psi_j``. This needs the driving point: without
a response at the force's DOF only the products ``psi_i psi_j`` of the
unmeasured ``psi_j`` are known and no scale follows. A driving-point
residue whose ``psi_j^2`` is not positive-real within ``PHASE_TOL`` (a wrong
sign, a mode the force barely excites, noise) gives no scale for that mode.

Assumptions and failures: linear time-invariant, the poles of the band
known (a mode missing from them biases its neighbours' residues); light,
near-proportional damping (the residues of general viscous damping are
``psi psi^T / a_r`` with a complex ``a_r``; the shapes are then complex and
their scale approximate); the force held over each sample (``step == dt``;
a finer hold changes the exact terms slightly); FRF leakage (Welch segments
short against ``1 / (zeta omega)``) biases the residues low.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

ZETA_MIN = 1e-5  # least damping ratio of a refined pole
EPS_FLOOR = 1e-3  # least normalized random error of a line (noise-free data: coherence 1)
PHASE_TOL = 0.35  # rad: largest phase of a driving-point psi_j^2 that still gives a scale
ORDERS = {"displacement": 0, "velocity": 1, "acceleration": 2}


@dataclass
class Fit:
    """A pole-residue fit: ``poles`` (k,) complex rad/s, ``residues`` (c, k)
    complex displacement residues (m/N/s per mode and channel), ``residual``
    (c, 4) real residual-term coefficients (zero-padded), ``model`` (c, m) the fitted FRF,
    ``misfit`` (c,) the weighted RMS residual (1: at the noise level);
    after :func:`refine`, ``omega_std`` rad/s and ``zeta_std`` (k,) of the
    refined poles (NaN for one that was not refined), else ``None``."""

    poles: np.ndarray
    residues: np.ndarray
    residual: np.ndarray
    model: np.ndarray
    misfit: np.ndarray
    omega_std: np.ndarray | None = None
    zeta_std: np.ndarray | None = None


def poles_of(omega: np.ndarray, zeta: np.ndarray) -> np.ndarray:
    """``lambda = -zeta omega + i omega sqrt(1 - zeta^2)`` (k,) from rad/s and damping ratios."""
    omega, zeta = np.asarray(omega, float), np.asarray(zeta, float)
    return -zeta * omega + 1j * omega * np.sqrt(np.clip(1.0 - zeta**2, 1e-12, None))


def _design(w: np.ndarray, dt: float, poles: np.ndarray, order: int, mu2: float = 0.0) -> np.ndarray:
    """Real design (2m, 2k + e) of one channel of derivative ``order`` at
    ``w`` (m,) rad/s: per pole the columns of ``Re R`` and ``Im R``, then the
    residual terms; rows: real parts, then imaginary parts. ``mu2``
    (rad/s)^2: each pole's term ``g`` is the Welch estimate's expectation
    to second order, ``g + mu2 g_ww / 2`` (see :func:`window_moment`)."""
    z = np.exp(1j * w * dt)[:, None]
    lam = poles[None, :]
    p = np.exp(lam * dt)

    def term(lam: np.ndarray, p: np.ndarray) -> np.ndarray:  # a / (z - p), plus mu2 / 2 times its d2/domega2
        a = lam**order * (p - 1.0) / lam
        return a / (z - p) - 0.5 * mu2 * a * dt**2 * z * (z + p) / (z - p) ** 3

    g, gc = term(lam, p), term(np.conj(lam), np.conj(p))  # R's term, conj(R)'s term
    hold = (1.0 - np.exp(-1j * w * dt)) / (1j * w * dt)
    powers = sorted({order, order - 2} - {0})
    extra = np.stack([np.ones_like(w), np.exp(-1j * w * dt)] + [hold * (1j * w) ** e for e in powers], axis=1)
    cols = np.hstack([g + gc, 1j * (g - gc), extra])  # R = a + i b: a (g + gc) + b i (g - gc)
    return np.vstack([cols.real, cols.imag])


def fit(w: np.ndarray, H: np.ndarray, sigma: np.ndarray, dt: float, poles: np.ndarray,
        orders: np.ndarray, mu2: float = 0.0) -> Fit:
    """Residues of ``H`` (c, m) at ``w`` (m,) rad/s for fixed ``poles`` (k,);
    ``sigma`` (c, m) the standard deviation of each line (``inf``: unused);
    ``orders`` (c,) each channel's derivative (0, 1, 2); ``mu2`` the Welch
    window's spectral second moment (:func:`window_moment`; 0: none).
    Batched over channels."""
    k = poles.size
    by_order = {int(o): _design(w, dt, poles, int(o), mu2) for o in set(orders.tolist())}
    A = np.zeros((len(orders), 2 * w.size, 2 * k + 4))  # residual columns padded to 4
    for i, o in enumerate(orders):
        A[i, :, :by_order[int(o)].shape[1]] = by_order[int(o)]
    P = np.array([by_order[int(o)].shape[1] for o in orders])
    inv = 1.0 / np.concatenate([sigma, sigma], axis=1)  # (c, 2m)
    b = np.concatenate([H.real, H.imag], axis=1)
    b = np.where(np.isfinite(b), b, 0.0)
    Aw, bw = A * inv[:, :, None], b * inv
    norms = np.linalg.norm(Aw, axis=1)
    norms[norms == 0] = 1.0
    coef = _solve(Aw / norms[:, None, :], bw) / norms
    model2 = np.einsum("cnp,cp->cn", A, coef)
    m = w.size
    model = model2[:, :m] + 1j * model2[:, m:]
    used = np.isfinite(inv) & (inv > 0)
    misfit = np.sqrt(np.sum(((bw - model2 * inv) ** 2) * used, axis=1) / np.maximum(used.sum(axis=1) - P, 1))
    return Fit(poles, coef[:, :k] + 1j * coef[:, k:2 * k], coef[:, 2 * k:], model, misfit)


def _solve(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Least-squares solutions (c, P) of the stacked ``A`` (c, n, P), unit
    columns (or zero), ``b`` (c, n): the normal equations by the small
    Gram matrices' eigendecomposition (directions below 1e-13 of the largest
    eigenvalue dropped) and one step of iterative refinement. Tall stacked
    LAPACK factorisations are avoided: on a busy machine their BLAS threads
    cost a hundred times the work."""
    G = np.einsum("cnp,cnq->cpq", A, A)
    vals, vecs = np.linalg.eigh(G)
    inv = np.where(vals > 1e-13 * vals[:, -1:], 1.0 / np.where(vals > 0, vals, 1.0), 0.0)

    def step(r: np.ndarray) -> np.ndarray:
        rhs = np.einsum("cnp,cn->cp", A, r)
        return np.einsum("cpq,cq,crq,cr->cp", vecs, inv, vecs, rhs)

    x = step(b)
    return x + step(b - np.einsum("cnp,cp->cn", A, x))


def refine(w: np.ndarray, H: np.ndarray, sigma: np.ndarray, dt: float, poles: np.ndarray,
           orders: np.ndarray, max_move: float = 0.05, mu2: float = 0.0) -> tuple[Fit, np.ndarray]:
    """:func:`fit` with the poles' ``omega`` and ``zeta`` fitted too
    (variable projection, bounded trust-region Gauss-Newton from ``poles``:
    each ``omega`` within ``max_move`` (relative) of its start, each ``zeta``
    in ``[ZETA_MIN, 0.5]``). Returns the fit and per pole (k,) whether it was
    refined: a pole that ends on a bound (a noise pole of the SSI, a mode the
    FRFs do not carry) keeps its start, as do all when the solver fails."""
    omega0, zeta0 = np.abs(poles), -poles.real / np.abs(poles)
    k = poles.size
    lower = np.concatenate([np.full(k, 1.0 - max_move), np.full(k, ZETA_MIN)])
    upper = np.concatenate([np.full(k, 1.0 + max_move), np.full(k, 0.5)])
    x0 = np.clip(np.concatenate([np.ones(k), zeta0]), lower * (1 + 1e-9), upper * (1 - 1e-9))

    def residual(x: np.ndarray) -> np.ndarray:
        f = fit(w, H, sigma, dt, poles_of(omega0 * x[:k], x[k:]), orders, mu2)
        r = (np.concatenate([(H - f.model).real, (H - f.model).imag], axis=1)
             / np.concatenate([sigma, sigma], axis=1))
        return np.where(np.isfinite(r), r, 0.0).ravel()

    try:
        sol = least_squares(residual, x0, bounds=(lower, upper), max_nfev=60 * (k + 1),
                            x_scale=np.concatenate([np.full(k, 1e-3), 0.1 * np.maximum(x0[k:], 1e-3)]))
    except (ValueError, np.linalg.LinAlgError):
        return fit(w, H, sigma, dt, poles, orders, mu2), np.zeros(k, bool)
    free = (sol.x > lower + 1e-6 * (upper - lower)) & (sol.x < upper - 1e-6 * (upper - lower))
    refined = free[:k] & free[k:] & (sol.status > 0)
    omega = np.where(refined, omega0 * sol.x[:k], omega0)
    zeta = np.where(refined, sol.x[k:], zeta0)
    out = fit(w, H, sigma, dt, np.where(refined, poles_of(omega, zeta), poles), orders, mu2)
    std = _pole_std(sol.jac, sol.fun, int(np.isfinite(sigma).sum()), orders, k)
    out.omega_std = np.where(refined, omega0 * std[:k], np.nan)
    out.zeta_std = np.where(refined, std[k:], np.nan)
    return out, refined


def window_moment(window: np.ndarray, dt: float) -> float:
    """Second moment ``mu2`` (rad/s)^2 of a Welch segment's spectral window
    ``|W(nu)|^2 / int |W|^2`` for the window samples ``window`` (N,) at
    ``dt`` s, by Parseval ``mu2 = sum (w_(n+1) - w_n)^2 / (dt^2 sum w_n^2)``
    (Hann: ``4 pi^2 / (3 (N dt)^2)``). For a force whose spectrum is flat
    across a mode, the expected cross spectrum is the true one convolved with
    that window, so the expected H1 is ``H + mu2 H_ww / 2 + ...`` (the next
    term, ``mu4 H_wwww / 24``, is ``(mu2 / (zeta omega)^2)^2`` smaller): a
    resonance looks wider, by about ``mu2 / (zeta omega)^2 / 2`` in zeta
    (Hann, 8 lines per half-power bandwidth: 0.4 % of zeta)."""
    w = np.asarray(window, float)
    return float(np.sum(np.diff(w) ** 2) / (dt**2 * np.sum(w**2)))


def _pole_std(J: np.ndarray, r: np.ndarray, lines: int, orders: np.ndarray, k: int) -> np.ndarray:
    """Standard errors (2 k,) of the variable-projection parameters from the
    Jacobian ``J`` (2 c m, 2 k) of the weighted residual ``r`` at the
    solution (the residues eliminated: the Gauss-Newton covariance of the
    poles with the residues free), ``s^2 (J^T J)^-1``, ``s^2 = |r|^2 /
    (2 lines - parameters)`` (the misfit, so that weights right only up to
    a common factor still give the right scale); ``lines`` (complex) FRF
    values used, ``orders`` (c,) the channels' derivatives (their residual
    terms count as parameters). Fails (too small) where the lines' errors
    are correlated more than the Welch segments' overlap makes them (see
    :mod:`identifier.modal.input_output`)."""
    params = 2 * k + 2 * k * orders.size + sum(2 + len({int(o), int(o) - 2} - {0}) for o in orders)
    s2 = float(r @ r) / max(2 * lines - params, 1)
    cov = np.linalg.pinv(J.T @ J) * s2
    return np.sqrt(np.clip(np.diag(cov), 0.0, None))


@dataclass
class Scaled:
    """Unit-modal-mass shapes ``psi`` (c, k) complex (NaN for a mode without
    scale; per sqrt(kg), in displacement at each sensor), ``modal_mass`` (k,)
    kg of the shape scaled to max abs 1 over the sensors (NaN without scale),
    ``reasons`` (k,) ``""`` or why a mode has no scale."""

    psi: np.ndarray
    modal_mass: np.ndarray
    reasons: list[str]


def scale(residues: np.ndarray, poles: np.ndarray, drive: int) -> Scaled:
    """Unit-modal-mass shapes from ``residues`` (c, k) and ``poles`` (k,)
    with the driving point at channel ``drive``: ``psi_j^2 = 2 i omega_d
    R_jj``, ``psi_i = 2 i omega_d R_ij / psi_j``; ``modal_mass = 1 /
    max_i |psi_i|^2``. A mode whose ``psi_j^2`` has a phase over
    ``PHASE_TOL`` or is 0 gets NaN and its reason."""
    a = 2j * poles.imag  # 2 i omega_d (k,)
    square = a * residues[drive]  # psi_j^2 (k,)
    phase = np.abs(np.angle(square))
    good = (np.abs(square) > 0) & (phase <= PHASE_TOL)
    psi_j = np.sqrt(square)  # principal root: the positive one for a positive-real square
    with np.errstate(divide="ignore", invalid="ignore"):
        psi = a[None, :] * residues / psi_j[None, :]
        mass = 1.0 / np.max(np.abs(psi) ** 2, axis=0)
    psi[:, ~good] = np.nan
    mass[~good] = np.nan
    reasons = ["" if g else (f"driving-point residue gives psi_j^2 of phase {np.degrees(ph):.0f} deg "
                             f"(needs a positive real value within {np.degrees(PHASE_TOL):.0f} deg): "
                             "the force barely excites this mode or the sign is wrong")
               for g, ph in zip(good, phase)]
    return Scaled(psi, mass, reasons)


def real_shapes(psi: np.ndarray) -> np.ndarray:
    """Real unit-modal-mass shapes (c, k): each complex column turned so its
    driving-point entry is real positive already (:func:`scale`), real part."""
    return np.real(psi)
