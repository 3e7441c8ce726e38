"""A record that holds a few sinusoids on many channels (a band-pass narrower than two lines): its block
Hankel matrix has a lower rank than the model orders, a basis vector of its leading subspace can lie in
the last block row alone, and the shifted Gram matrix ``G`` is then singular from that order on. Before
``Subspace.orders`` the Cholesky factor of ``G`` raised ``LinAlgError`` out of ``modal.identify``
(held-out record 1,028,000 band-passed by FFT: 31 channels, 170 samples)."""
from __future__ import annotations

import numpy as np
import pytest
from modal_fuzz import unseen_trace

from structbench.identifier import modal
from structbench.identifier.modal.ssi.poles import subspace


def test_orders_stop_before_a_basis_vector_in_the_last_block_row():
    rng = np.random.default_rng(0)
    m, rows = 3, 5
    B = np.linalg.qr(rng.standard_normal((m * rows, 6)))[0]
    B[:, 4] = 0.0
    B[-m:, 4] = rng.standard_normal(m)  # basis vector 4: in the last block row only
    B[:, 4] /= np.linalg.norm(B[:, 4])
    space = subspace(B, m)
    assert space.orders == 4
    assert space.whitened[0].shape == (4, 4)
    full = subspace(np.linalg.qr(rng.standard_normal((m * rows, 6)))[0], m)
    assert full.orders == 6


@pytest.mark.parametrize("seed", [14, 21, 23, 27])  # each raised LinAlgError before
def test_two_lines_on_many_channels_are_a_harmonic_not_a_crash(seed):
    rng = np.random.default_rng(seed)
    n, m, dt = int(rng.integers(120, 400)), int(rng.integers(8, 40)), 0.1
    spectrum = np.zeros((m, n // 2 + 1), complex)
    k = int(rng.integers(5, n // 2 - 3))
    spectrum[:, k:k + 2] = rng.standard_normal((m, 2)) + 1j * rng.standard_normal((m, 2))
    y = np.fft.irfft(spectrum, n, axis=1)
    result = modal.identify([unseen_trace({"y": y, "dt": dt, "quantities": ["displacement"] * m,
                                           "noise": np.zeros(m)})])
    assert result.omega == []
    assert [h["omega"] for h in result.details["harmonics"]] == [pytest.approx(2 * np.pi * k / (n * dt))]
