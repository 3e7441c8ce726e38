"""Weighted modal residuals of an affine model and their analytic Jacobian.

For measured mode ``i`` paired with model mode ``j`` (see :meth:`Residuals.pair`):

- eigenvalue: ``r_i = (lambda_j(alpha) - lambda_i^meas) / lambda_i^meas / s_i``
  with ``s_i`` the stated relative standard error ``std(lambda_i) / lambda_i``
  (1 when none is stated: unit weight);
- shape (modes with a measured shape ``b`` (m,)): the model shape at the
  measured DOF ``a = phi_j[sensors]`` scaled to ``b``, minus ``b``:
  ``r = W^(1/2) (c a - b)``, ``W = diag(1 / std(b)^2)`` (identity when no
  standard errors are stated), invariant to the scaling and sign of either
  shape. Two scalings (``scaling``):

  - ``least-squares``: ``c = a^T W b / a^T W a`` (weighted least squares, the
    scale profiled out: ``m - 1`` independent data per shape, the right
    statistics near the answer). Its derivative
    ``dr = W^(1/2) (a dc + c da)``, ``dc = (b - 2 c a)^T W da / a^T W a``.
    Its squared norm is ``b^T W b (1 - MAC_W(a, b))``: as flat as MAC values
    far from the answer, where a model mode with little motion at the sensors
    gives ``r = -b`` whatever the parameters.
  - ``entry``: ``c = b_q / a_q`` at the entry ``q`` where ``|b|`` is largest,
    that entry dropped (``m - 1`` rows), ``dc = -c da_q / a_q``: the
    reference package's eigenvector-difference residual, which grows without
    bound as the model shape loses the reference entry and so leads a search
    from far away (used for the starts; the noise of ``b_q`` enters every row,
    which the least-squares scaling avoids).

Eigenvalue and eigenvector derivatives come from :mod:`.sensitivity`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from structbench.models.mac import mac

from .data import ModalData
from .sensitivity import AffineModel

FREQUENCY_TIE = 0.05  # weight of |log(lambda_model / lambda_meas)| beside 1 - MAC in the pairing cost


@dataclass
class Evaluation:
    """Residuals ``r`` (n,), Jacobian ``J`` (n, q), the model mode paired with
    each measured mode ``pairs`` (k,), the model eigenvalues of the pairs
    ``lam`` (k,), their MAC ``mac`` (k,, NaN without a shape) and the shape
    scales ``scale`` (k,)."""

    r: np.ndarray
    J: np.ndarray
    pairs: np.ndarray
    lam: np.ndarray
    mac: np.ndarray
    scale: np.ndarray


class Residuals:
    """Residual function of ``data`` for ``model`` (see the module docstring)."""

    def __init__(self, model: AffineModel, data: ModalData, scaling: str = "least-squares",
                 extra_modes: int | None = None) -> None:
        self.model, self.data, self.scaling = model, data, scaling
        k = data.lam.size
        self.k = k
        self.count = min(model.n, k + (extra_modes if extra_modes is not None else max(k // 2, 4)))
        self.shaped = ~np.all(np.isnan(data.shapes), axis=0)
        self.rel_std = np.where(np.isfinite(data.lam_std) & (data.lam_std > 0), data.lam_std / data.lam, 1.0)
        self.b = np.nan_to_num(data.shapes)
        std = data.shape_std
        self.sqrt_w = np.where(np.isfinite(std) & (std > 0), 1.0 / np.where(std > 0, std, 1.0), 1.0)
        self.entry = np.argmax(np.abs(self.b), axis=0)  # reference entry of each measured shape
        m = model.sensors.size - (scaling == "entry")
        self.n_res = k + int(self.shaped.sum()) * m
        self.n_scales = int(self.shaped.sum()) if scaling == "least-squares" else 0
        self._cache: tuple[bytes, Evaluation] | None = None
        self.switches = 0
        self._last_pairs: np.ndarray | None = None
        self.numbers: np.ndarray | None = None

    def fix_pairs(self, numbers: np.ndarray | None) -> None:
        """Pair measured mode ``i`` with the ``numbers[i]``-th lowest model mode
        at every evaluation (None: pair by MAC at every evaluation)."""
        self.numbers, self._cache = (None if numbers is None else np.asarray(numbers, dtype=int)), None
        if numbers is not None:
            self.count = max(self.count, int(np.max(numbers)) + 1)

    @property
    def stated(self) -> dict[str, bool]:
        """Whether every eigenvalue / every shape entry has a stated standard error."""
        shaped = self.data.shape_std[:, self.shaped]
        return {"eigenvalues": bool(np.all(np.isfinite(self.data.lam_std) & (self.data.lam_std > 0))),
                "shapes": bool(shaped.size == 0 or np.all(np.isfinite(shaped) & (shaped > 0)))}

    def cost(self, lam: np.ndarray, at_sensors: np.ndarray) -> np.ndarray:
        """Pairing cost (c, k) of model modes ``lam`` (c,), shapes ``at_sensors``
        (m, c), against the measured ones: ``1 - MAC`` (modes with a shape)
        plus ``FREQUENCY_TIE |log(lambda ratio)|`` (the ratio capped at e^20)."""
        ratio = np.abs(np.log(np.maximum(lam[:, None], 1e-300) / self.data.lam[None, :]))
        cost = FREQUENCY_TIE * np.minimum(ratio, 20.0)
        if self.shaped.any():
            cost[:, self.shaped] += 1.0 - mac(at_sensors, self.b[:, self.shaped])
        return cost

    def pair(self, lam: np.ndarray, at_sensors: np.ndarray) -> np.ndarray:
        """Model mode for each measured one: the one-to-one assignment of
        least total :meth:`cost`."""
        rows, cols = linear_sum_assignment(self.cost(lam, at_sensors))
        pairs = np.empty(self.k, dtype=int)
        pairs[cols] = rows
        return pairs

    def __call__(self, alpha: np.ndarray) -> Evaluation:
        key = np.asarray(alpha, dtype=float).tobytes()
        if self._cache is not None and self._cache[0] == key:
            return self._cache[1]
        model = self.model
        M, K = model.matrices(alpha)
        lam_all, phi_all = model.modes(M, K, self.count, self.k + 2 if self.numbers is None
                                       else int(np.max(self.numbers)) + 1)
        if self.numbers is None:
            pairs = self.pair(lam_all, phi_all[model.sensors])
            if self._last_pairs is not None and np.any(pairs != self._last_pairs):
                self.switches += 1
            self._last_pairs = pairs
        else:
            pairs = self.numbers
        r, J = np.empty(self.n_res), np.empty((self.n_res, model.q))
        macs, scales = np.full(self.k, np.nan), np.full(self.k, np.nan)
        row = self.k
        for i, j in enumerate(pairs):
            lam, phi = lam_all[j], phi_all[:, j]
            dlam, dphi = model.derivatives(M, K, lam, phi, shapes=bool(self.shaped[i]))
            lam_e = self.data.lam[i]
            r[i] = (lam - lam_e) / lam_e / self.rel_std[i]
            J[i] = dlam / lam_e / self.rel_std[i]
            if not self.shaped[i]:
                continue
            a, b, sw = phi[model.sensors], self.b[:, i], self.sqrt_w[:, i]
            macs[i] = float(np.sum(a * b) ** 2 / (np.sum(a * a) * np.sum(b * b)))
            if self.scaling == "entry":
                q = self.entry[i]
                aq = a[q] if abs(a[q]) > 1e-300 else 1e-300
                c = b[q] / aq
                dc = -c / aq * dphi[q]
                keep = np.arange(a.size) != q
                a, b, sw, dphi = a[keep], b[keep], sw[keep], dphi[keep]
            else:
                w = sw**2
                aw = np.sum(w * a * a)
                c = np.sum(w * a * b) / aw
                dc = ((b - 2 * c * a) * w) @ dphi / aw
            m = a.size
            r[row:row + m] = sw * (c * a - b)
            J[row:row + m] = sw[:, None] * (np.outer(a, dc) + c * dphi)
            scales[i] = c
            row += m
        out = Evaluation(r, J, pairs, lam_all[pairs], macs, scales)
        self._cache = (key, out)
        return out

    def leverage_of_scales(self, ev: Evaluation) -> np.ndarray:
        """Leverage (n,) of the profiled shape scales on each residual:
        ``w_l a_l^2 / a^T W a`` on the shape rows of a mode, 0 on eigenvalue rows."""
        h = np.zeros(self.n_res)
        row = self.k
        for i in np.flatnonzero(self.shaped):
            m = self.model.sensors.size
            a = (ev.r[row:row + m] / self.sqrt_w[:, i] + self.b[:, i]) / ev.scale[i]
            wa2 = self.sqrt_w[:, i] ** 2 * a**2
            h[row:row + m] = wa2 / wa2.sum()
            row += m
        return h
