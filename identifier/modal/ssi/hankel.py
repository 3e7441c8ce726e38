"""The block Hankel matrix of SSI-cov as an operator: products by FFT, and
its leading singular subspace by randomised subspace iteration.

For lagged covariances ``R_l`` (l = 1..L; stored 0-based as ``R[l - 1]``,
(L, m, r)) the block Hankel matrix of ``p`` block rows and ``q`` block columns
has block (i, j) = ``R[i + j]`` ((p m) x (q r), ``p + q - 1 <= L``). Its
products are correlations along the lag axis:

    (H X)_i = sum_j R[i + j] X_j,        (H^T Y)_j = sum_i R[i + j]^T Y_i,

for ``X`` (q r, k) in blocks ``X_j`` (r, k) and ``Y`` (p m, k) in blocks ``Y_i``
(m, k). With ``hat`` the real FFT of length ``F >= p + q - 1`` over the lag
or block index, ``hat(H X)(f) = hat R(f) conj(hat X(f))`` (and ``hat R(f)^T``
for the transpose): ``(F / 2) m r k`` complex products and ``(m + r) k`` FFTs
instead of ``p q m r k`` products, which is what makes long lag spans
affordable. A stack of covariance sequences (..., L, m, r) gives a stack of
operators (the jackknife's replicates) that share the input's FFT. The matrix
is never formed (:meth:`BlockHankel.dense` does, for checks).
"""
from __future__ import annotations

from collections import OrderedDict
from threading import Lock

import numpy as np
import scipy.fft as sfft
import scipy.linalg as la

from ..runtime import irfft, rfft


class BlockHankel:
    """Block Hankel operator(s) of ``p`` block rows and ``q`` block columns of
    the lagged covariances ``R`` (..., L, m, r), ``L >= p + q - 1``."""

    def __init__(self, R: np.ndarray, rows: int, columns: int):
        self.rows, self.columns = rows, columns
        self.m, self.r = R.shape[-2], R.shape[-1]
        self.size = sfft.next_fast_len(rows + columns - 1, real=True)
        self.spectrum = rfft(R[..., :rows + columns - 1, :, :], n=self.size, axis=-3)  # (..., f, m, r)

    @property
    def shape(self) -> tuple[int, int]:
        return self.rows * self.m, self.columns * self.r

    def __matmul__(self, X: np.ndarray) -> np.ndarray:
        """``H X``, (..., p m, k) from ``X`` (q r, k) or (..., q r, k)."""
        return self._correlate(self.spectrum, self.transform(X, self.columns), self.columns, self.rows)

    def rmatmul(self, Y: np.ndarray, transformed: np.ndarray | None = None) -> np.ndarray:
        """``H^T Y``, (..., q r, k) from ``Y`` (p m, k) or (..., p m, k), or from
        its :meth:`transform` when given (one FFT for several operators)."""
        Yf = self.transform(Y, self.rows) if transformed is None else transformed
        return self._correlate(np.swapaxes(self.spectrum, -1, -2), Yf, self.rows, self.columns)

    def probe(self, width: int) -> np.ndarray:
        """``H Omega`` (..., p m, width) for the fixed-seed Gaussian probe
        ``Omega`` (q r, width) of the subspace iteration (:func:`_probe_spectrum`)."""
        return self._correlate(self.spectrum, _probe_spectrum(self.columns, self.r, width, self.size),
                               self.columns, self.rows)

    def transform(self, X: np.ndarray, blocks: int) -> np.ndarray:
        """FFT (..., f, width, k) of the ``blocks`` blocks of ``X`` in reverse order."""
        return _reversed_spectrum(X, blocks, self.size)

    def _correlate(self, spectrum: np.ndarray, Xf: np.ndarray, blocks_in: int, blocks_out: int) -> np.ndarray:
        """``Z_i = sum_j R[i + j] X_j`` for i < ``blocks_out``: the convolution of
        ``R`` with the blocks of ``X`` in reverse order (``Xf``, their FFT), read
        from ``blocks_in - 1``."""
        Z = irfft(spectrum @ Xf, n=self.size, axis=-3)
        return Z[..., blocks_in - 1:blocks_in - 1 + blocks_out, :, :].reshape(*Z.shape[:-3], -1, Xf.shape[-1])

    def dense(self) -> np.ndarray:
        """The matrix itself (..., p m, q r), by its definition."""
        R = irfft(self.spectrum, n=self.size, axis=-3)
        idx = np.arange(self.rows)[:, None] + np.arange(self.columns)[None, :]
        blocks = R[..., idx, :, :]  # (..., p, q, m, r)
        return np.swapaxes(blocks, -3, -2).reshape(*blocks.shape[:-4], *self.shape)


def leading_svd(H: BlockHankel, count: int, power: int = 2) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``U`` (p m, count), ``s`` (count,), ``V`` (q r, count): the leading
    singular triplets of ``H`` by subspace iteration (Halko, Martinsson and
    Tropp 2011): ``power`` steps from ``H`` times a fixed-seed Gaussian probe
    of ``count + 10`` columns, then the SVD ``U_b S W^T`` of the small ``Q^T
    H`` from the eigen-decomposition of ``Z^T Z`` alone, ``Z = H^T Q``
    (``Q^T H H^T Q = U_b S^2 U_b^T``, so ``U = Q U_b`` and ``V = Z U_b
    S^-1``): a third of the cost of a QR of the tall ``Z``, accurate to
    about ``eps s_1^2 / s_i^2`` relative (a mode 10^-5 below the strongest
    in a noise-free free decay: frequency within 1e-8), far below the noise
    of any singular value a model order uses. The leading vectors
    converge as ``(s_(count+10) / s_i)^(2 power + 1)``: exact for a matrix
    of rank below ``count + 10``, accurate for the structural (signal) part
    of a noisy one. Between steps the basis only needs to span the iterate:
    a pivoted LU (a quarter of the cost of a Householder QR) keeps it well
    scaled; the last basis is orthonormal (QR)."""
    width = min(count + 10, *H.shape)
    Y = H.probe(width)
    for _ in range(power):
        Y = H @ H.rmatmul(la.lu(Y, permute_l=True, overwrite_a=True, check_finite=False)[0])  # P L of Y = P L U
    Q = la.qr(Y, mode="economic", overwrite_a=True)[0]
    Z = H.rmatmul(Q)  # (q r, width) = (Q^T H)^T
    s2, Ub = la.eigh(Z.T @ Z, overwrite_a=True, check_finite=False)
    s2, Ub = s2[::-1][:count], Ub[:, ::-1][:, :count]
    s = np.sqrt(np.maximum(s2, s2[0] * np.finfo(float).eps ** 2))  # a numerical zero stays finite
    return Q @ Ub, s, (Z @ Ub) / np.where(s > 0, s, 1.0)


def _reversed_spectrum(X: np.ndarray, blocks: int, size: int) -> np.ndarray:
    """FFT of length ``size`` (..., f, width, k) of the ``blocks`` blocks of
    ``X`` (..., blocks width, k) in reverse order."""
    reverse = X.reshape(*X.shape[:-2], blocks, -1, X.shape[-1])[..., ::-1, :, :]
    return rfft(reverse, n=size, axis=-3)


PROBE_BYTES = 64 << 20  # probe spectra kept, at most (:func:`_probe_spectrum`)
_probes: OrderedDict[tuple[int, int, int, int], np.ndarray] = OrderedDict()
_probes_lock = Lock()


def _probe_spectrum(columns: int, references: int, width: int, size: int) -> np.ndarray:
    """The FFT (:meth:`BlockHankel.transform`, read-only) of the Gaussian
    probe (``columns`` x ``references``, ``width``) drawn from seed 0: a
    constant of the method, made once per shape and process and kept while the spectra
    of the most recent shapes take at most ``PROBE_BYTES`` (one lock for
    identifications in several threads)."""
    key = (columns, references, width, size)
    with _probes_lock:
        if key in _probes:
            _probes.move_to_end(key)
            return _probes[key]
        probe = np.random.default_rng(0).standard_normal((columns * references, width))
        spectrum = _reversed_spectrum(probe, columns, size)
        spectrum.flags.writeable = False
        _probes[key] = spectrum
        while len(_probes) > 1 and sum(a.nbytes for a in _probes.values()) > PROBE_BYTES:
            _probes.popitem(last=False)
        return spectrum
