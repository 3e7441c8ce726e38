"""The building blocks of the modal method against independent references:
lagged covariance sums by FFT against the lag-by-lag products, Hankel
products by FFT against the explicit block Hankel matrix, the leading
singular triplets against LAPACK's SVD, and the default Hankel sizes against
their stated rules (record length, lowest frequency, free decay or not)."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from structbench.identifier.modal.ssi.covariance import covariances, group_labels, is_free_decay, reference_channels
from scipy.signal import welch

from structbench.identifier.modal.ssi.design import ROW_BUDGET, block_sizes, lowest_frequency, welch_power
from structbench.identifier.modal.ssi import hankel as ssi_hankel
from structbench.identifier.modal.ssi.hankel import BlockHankel, leading_svd
from structbench.identifier.modal.ssi.poles import Poles
from structbench.models.mac import mac
from structbench.identifier.modal.stabilisation import Criteria, median, stable_flags


def lag_by_lag(records, lags, references, groups):
    """``sum_{k in group} z_{k+l} z_ref,k^T`` by one matrix product per lag and group (the definition)."""
    m = records[0].shape[0]
    scale = np.sqrt(np.mean(np.concatenate(records, axis=1) ** 2, axis=1))
    refs = reference_channels(m, references)
    sums, counts = np.zeros((groups, lags, m, refs.size)), np.zeros((groups, lags))
    for y in records:
        z = y / scale[:, None]
        labels = group_labels(z.shape[1] - lags, groups, lags, is_free_decay(z))
        for g in range(groups):
            k = np.flatnonzero(labels == g)
            for lag in range(1, lags + 1):
                sums[g, lag - 1] += z[:, k + lag] @ z[refs][:, k].T
            counts[g] += k.size
    return sums, counts


def test_covariance_sums_by_fft_are_the_lagged_products():
    """A free decay (interleaved groups) and a stationary record (contiguous
    groups) add up as two tests; 4 of 6 channels are references."""
    rng = np.random.default_rng(0)
    decay = rng.standard_normal((6, 3000)) * np.exp(-np.arange(3000) / 200.0)
    stationary = rng.standard_normal((6, 2500))
    assert is_free_decay(decay) and not is_free_decay(stationary)
    for records in ([decay], [stationary], [decay, stationary]):
        cov = covariances(records, 0.1, 37, 4, 5)
        sums, counts = lag_by_lag(records, 37, 4, 5)
        assert cov.sums == pytest.approx(sums, abs=1e-12 * np.abs(sums).max())
        assert np.array_equal(cov.counts, counts)


@pytest.mark.parametrize("rows, columns", [(30, 11), (7, 20), (1, 1), (2, 39)])
def test_hankel_products_by_fft_are_the_matrix_products(rows, columns):
    rng = np.random.default_rng(1)
    R = rng.standard_normal((3, 40, 5, 3))  # a stack of three covariance sequences
    explicit = np.zeros((3, rows * 5, columns * 3))
    for i in range(rows):
        for j in range(columns):
            explicit[:, 5 * i:5 * i + 5, 3 * j:3 * j + 3] = R[:, i + j]
    H = BlockHankel(R, rows, columns)
    X, Y = rng.standard_normal((columns * 3, 4)), rng.standard_normal((3, rows * 5, 4))
    assert H.dense() == pytest.approx(explicit, abs=1e-13)
    assert H @ X == pytest.approx(explicit @ X, abs=1e-12)
    assert H.rmatmul(Y) == pytest.approx(np.swapaxes(explicit, 1, 2) @ Y, abs=1e-12)
    one = BlockHankel(R[1], rows, columns)
    assert one.rmatmul(Y[2], one.transform(Y[2], rows)) == pytest.approx(explicit[1].T @ Y[2], abs=1e-12)


def test_the_kept_probe_is_the_seed_zero_gaussian_and_its_spectra_stay_bounded(monkeypatch):
    """``H.probe(k)`` is ``H`` times the Gaussian probe of seed 0, whether
    its spectrum was just made or kept; past ``PROBE_BYTES`` the oldest
    shapes' spectra are dropped (the newest is always kept)."""
    R = np.random.default_rng(5).standard_normal((60, 4, 3))
    monkeypatch.setattr(ssi_hankel, "_probes", type(ssi_hankel._probes)())
    monkeypatch.setattr(ssi_hankel, "PROBE_BYTES", 20_000)  # two of these 8.7 kB spectra
    for rows in (10, 20, 30, 10):
        H = BlockHankel(R, rows, 50 - rows)
        probe = np.random.default_rng(0).standard_normal((H.shape[1], 7))
        assert H.probe(7) == pytest.approx(H.dense() @ probe, abs=1e-12)
        kept = [a.nbytes for a in ssi_hankel._probes.values()]
        assert sum(kept) <= 20_000
    assert list(ssi_hankel._probes) == [(20, 3, 7, 50), (40, 3, 7, 50)]  # rows 30 and 10 again


@pytest.mark.parametrize("rows, columns", [(50, 29), (20, 59)])  # tall and wide
def test_leading_singular_triplets_of_a_low_rank_hankel_are_lapacks(rows, columns):
    """Covariances of three damped oscillations (rank 6): the randomised
    subspace iteration gives the six leading triplets of the full SVD."""
    rng = np.random.default_rng(2)
    lags = np.arange(1, 80)
    poles = np.exp((-0.01 + 1j * np.array([0.3, 0.7, 1.3]))[:, None] * lags)  # (3, L)
    C, G = rng.standard_normal((4, 3)) + 0j, rng.standard_normal((3, 2)) + 0j
    R = np.einsum("mk,kl,kr->lmr", C, poles, G).real
    H = BlockHankel(R, rows, columns)
    U, s, V = leading_svd(H, 6, power=1)
    U0, s0, V0t = np.linalg.svd(H.dense())
    assert s == pytest.approx(s0[:6], rel=1e-10)
    assert np.abs(U.T @ U0[:, :6]) == pytest.approx(np.eye(6), abs=1e-8)
    assert np.abs(V.T @ V0t[:6].T) == pytest.approx(np.eye(6), abs=1e-8)


def test_lowest_frequency_is_where_two_percent_of_the_power_lies():
    """Two sinusoids, 0.5 Hz (5 % of the power) and 4 Hz, and weak white
    noise: 2 % of the power lies below the 0.5 Hz line."""
    t = np.arange(40_000) * 0.01
    rng = np.random.default_rng(3)
    y = np.sqrt(0.05) * np.sin(2 * np.pi * 0.5 * t) + np.sqrt(0.95) * np.sin(2 * np.pi * 4.0 * t)
    records = [np.vstack([y, y]) + 0.01 * rng.standard_normal((2, t.size))]
    assert lowest_frequency(records, 0.01, np.arange(2)) == pytest.approx(0.5, abs=0.02)


@pytest.mark.parametrize("size, batch", [(256, 1 << 22), (255, 1 << 22), (256, 1000)])
def test_welch_power_is_scipys_welch_up_to_its_scale(size, batch):
    """Summed over three channels, for even and odd segments and in batches
    of a few segments: scipy.signal.welch's density spectrum, times one
    constant (its ``fs sum(window^2)``)."""
    z = np.random.default_rng(4).standard_normal((3, 5000)) + np.arange(3)[:, None]
    f, P = welch(z, fs=20.0, nperseg=size, axis=1)
    ours = welch_power(z, size, batch)
    assert ours.shape == f.shape
    assert ours / P.sum(axis=0) == pytest.approx(np.full(f.size, ours[1] / P.sum(axis=0)[1]), rel=1e-10)


def test_block_sizes_follow_their_rules():
    # free decay: rows from the budget or 4/5 of n / 20, columns a quarter of the rows
    assert block_sizes(10_001, 10, 10, 10, 80, 0.01, True, 0.0) == (400, 100)
    assert block_sizes(4_001, 10, 10, 10, 80, 0.01, True, 0.0) == (160, 40)
    assert block_sizes(4_001, 10, 10, 10, 80, 0.01, True, 0.0, rows=20) == (20, 12)  # 1.5 x 80 / 10 columns
    # stationary: the columns extend the span to a quarter period of f_low (0.05 Hz at 100 Hz: 500 + 1 lags)
    rows, columns = block_sizes(360_000, 100, 20, 20, 80, 0.01, False, 0.05)
    assert (rows, columns) == (ROW_BUDGET // 20, 501 - ROW_BUDGET // 20)
    # ... but never past n / 20 or the budget of the covariance sums (4e6 / (100 x 20) = 2000 lags)
    assert sum(block_sizes(360_000, 100, 20, 20, 80, 0.01, False, 0.001)) == 2000
    assert sum(block_sizes(20_000, 10, 10, 10, 80, 0.01, False, 0.001)) == 1000


@settings(max_examples=200, derandomize=True, deadline=None)
@given(st.lists(st.floats(-1e300, 1e300), min_size=1, max_size=60))
def test_median_of_a_few_values_is_numpys(values):
    assert median(values) == np.median(values)


def test_stable_flags_are_the_pairwise_definition():
    """Random orders of 0-12 poles near a few true ones (frequencies,
    damping ratios, unit shapes on 5 channels; each of the three jittered
    about as far as its tolerance in a quarter of them, two modes'
    damping ratios near the bounds, -0.02 and zeta_max): the flags of all
    neighbouring orders at once are those of the stated criteria order by
    order."""
    rng = np.random.default_rng(6)
    true, damping = np.array([1.0, 1.005, 2.0, 3.0]), np.array([0.01, -0.022, 0.2, 0.01])
    poles = []
    for order in range(2, 82, 2):
        k = int(rng.integers(0, 13))
        pick = rng.integers(0, true.size, k)
        loose = rng.random((3, k)) < 1 / 4
        omega = true[pick] * (1 + np.where(loose[0], 0.01, 0.002) * rng.standard_normal(k))
        zeta = damping[pick] * (1 + np.where(loose[1], 0.12, 0.02) * rng.standard_normal(k))
        shapes = np.eye(5)[:, pick] + np.where(loose[2], 0.2, 0.05) * (rng.standard_normal((5, k)) + 0j)
        shapes /= np.linalg.norm(shapes, axis=0)
        poles.append(Poles(order, omega, zeta, shapes, np.zeros(order), np.zeros((order, order)), np.arange(k)))
    criteria = Criteria()
    expected = [np.zeros(poles[0].omega.size, dtype=bool)]
    for prev, cur in zip(poles, poles[1:]):
        ok = np.array([any(abs(w - v) / w < criteria.freq_tol
                           and abs(z - y) < criteria.zeta_tol * (abs(z) + 0.002)
                           and mac(cur.shapes[:, [i]], prev.shapes[:, [j]])[0, 0] > criteria.mac_min
                           for j, (v, y) in enumerate(zip(prev.omega, prev.zeta)))
                       and -0.02 < z < criteria.zeta_max for i, (w, z) in enumerate(zip(cur.omega, cur.zeta))],
                      dtype=bool)
        expected.append(ok)
    flags = stable_flags(poles, criteria)
    assert [f.tolist() for f in flags] == [e.tolist() for e in expected]
    assert 10 < sum(int(f.sum()) for f in flags) < sum(f.size for f in flags)  # some stable, not all


def test_free_decay_is_decided_whatever_the_channels_units():
    """One decaying channel among stationary ones: scaling any channel (a
    displacement in m beside an acceleration in m/s^2) changes nothing; the
    decision is the one per-channel RMS scaling gives."""
    rng = np.random.default_rng(1)
    decay = rng.standard_normal((3, 4000)) * np.exp(-np.arange(4000) / 300.0)
    stationary = rng.standard_normal((3, 4000))
    for units in ([1.0, 1.0, 1.0], [1e6, 1.0, 1e-6], [1e-6, 1e3, 1.0]):
        scale = np.array(units)[:, None]
        assert is_free_decay(decay * scale)
        assert not is_free_decay(stationary * scale)
    mixed = np.vstack([decay[:1] * 1e-6, stationary[:2] * 1e3])  # a tiny decaying channel still counts
    assert is_free_decay(mixed) == is_free_decay(np.vstack([decay[:1], stationary[:2]]))
