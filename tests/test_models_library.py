"""The dissertation's structures against its tables and closed forms."""
import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from structbench.models import load_model
from structbench.models.analysis import DENSE_LIMIT, modes
from structbench.models.library import ch5_simply_supported_beam, ch5_simply_supported_fe

TABLE_3_4_ACTUAL = [0, 0, 0.064455, 0.206939, 0.408213, 0.719599, 1.096452, 1.524039, 1.999755, 2.575960]
TABLE_5_2_ACTUAL = [0, 1.1912, 1.1915, 2.7641, 5.8445, 5.8544, 7.8315, 9.4418, 12.0000,
                    12.0000, 15.3027, 16.0685, 17.8975, 25.1564, 25.6702, 29.5497]


def test_ch3_frequencies_match_table_3_4_to_six_digits():
    omega = load_model("ch3-free-free-beam").modes(10).omega
    # the table prints six decimals (six significant digits from mode 4 on)
    np.testing.assert_array_equal(np.round(omega, 6), TABLE_3_4_ACTUAL)
    np.testing.assert_allclose(omega[2:], TABLE_3_4_ACTUAL[2:], rtol=1e-5)


def test_ch5_membrane_eigenvalues_match_table_5_2_to_four_digits():
    lam = load_model("ch5-membrane").modes().lam
    nonzero = np.array(TABLE_5_2_ACTUAL) != 0
    np.testing.assert_allclose(lam[nonzero], np.array(TABLE_5_2_ACTUAL)[nonzero], rtol=5e-5)
    assert abs(lam[0]) < 1e-12


def test_ch5_modal_beam_is_exact():
    beam = ch5_simply_supported_beam()
    r = np.arange(1, 16)
    np.testing.assert_array_equal(beam.omega, (r * np.pi / 10.0) ** 2)
    np.testing.assert_allclose(beam.modes(3).omega, (np.arange(1, 4) * np.pi / 10) ** 2, rtol=1e-15)


def test_ch5_fe_beam_converges_to_the_continuous_beam():
    exact = ch5_simply_supported_beam().omega[:10]
    err20 = ch5_simply_supported_fe(20).modes(10).omega / exact - 1
    err40 = ch5_simply_supported_fe(40).modes(10).omega / exact - 1
    # Hermite cubics with consistent mass: error ~ (kh)^4, always from above.
    assert np.all(err20 > 0) and np.all(err40 > 0)
    assert np.all(np.abs(err20[:7]) < 1e-3)        # 20 elements: modes 1-7 within 0.1 %
    assert np.all(np.abs(err20) < 5e-3)            # mode 10 (2 elements per half-wave): 0.39 %
    assert np.all(np.abs(err40) < 1e-3)            # 40 elements: all ten within 0.1 %
    np.testing.assert_allclose(err20[5:] / err40[5:], 16.0, rtol=0.1)


@pytest.mark.parametrize("name, rigid", [("ch3-free-free-beam", 2), ("ch4-cantilever-case1", 0),
                                         ("ch4-cantilever-case2", 0), ("ch5-membrane", 1),
                                         ("ch5-simply-supported-beam-fe", 0),
                                         ("docs/examples/shear-frame-3.toml", 0)])
def test_rigid_body_modes_per_boundary_condition(name, rigid):
    model = load_model(name)
    k = model.stiffness().toarray()
    m = model.mass().toarray()
    np.testing.assert_allclose(m, m.T, atol=0)
    np.testing.assert_allclose(k, k.T, atol=0)
    assert np.linalg.eigvalsh(m).min() > 0
    ev = np.linalg.eigvalsh(k)
    assert ev.min() > -1e-10 * ev.max()
    assert np.sum(ev < 1e-10 * ev.max()) == rigid
    assert np.sum(model.modes().omega == 0.0) == rigid


def test_postulated_models_have_the_table_4_1_initial_error():
    for case, expected in (("case1", 0.122), ("case2", 0.0293)):
        true = load_model(f"ch4-cantilever-{case}").values
        post = load_model(f"ch4-cantilever-{case}-postulated").values
        mask = true != 0
        rms = np.sqrt(np.mean(((post[mask] - true[mask]) / true[mask]) ** 2))
        assert rms == pytest.approx(expected, abs=5e-4)


def test_sparse_shift_invert_agrees_with_dense_on_a_large_free_beam():
    from scipy.linalg import eigh

    from structbench.models.analysis import DENSE_LIMIT
    from structbench.models.library import beam

    rng = np.random.default_rng(5)
    n = 320
    model = beam("long", list(rng.uniform(1, 8, n)), list(rng.uniform(1, 6, n)), float(n))
    assert model.n_dof > DENSE_LIMIT
    sparse = model.modes(8)
    dense = eigh(model.stiffness().toarray(), model.mass().toarray(), eigvals_only=True,
                 subset_by_index=[0, 7])
    assert np.sum(sparse.lam == 0.0) == 2
    # dense LAPACK's absolute error is ~ eps x the largest eigenvalue, so the
    # tiny low eigenvalues of a long beam agree only to about 1e-6
    np.testing.assert_allclose(sparse.lam[2:], dense[2:], rtol=1e-5)
    k, m = model.stiffness(), model.mass()
    v = sparse.shapes[:, 2:]
    residual = np.linalg.norm(k @ v - m @ v * sparse.lam[2:], axis=0) / np.linalg.norm(k @ v, axis=0)
    assert residual.max() < 1e-6


def test_sparse_modes_do_not_depend_on_what_arpack_computed_before():
    """Above DENSE_LIMIT the Lanczos start is fixed: the same matrices give the
    same modes to the last bit after another eigsh call has moved ARPACK's own
    generator (its default start gave 1e-14 apart and flipped signs)."""
    n = DENSE_LIMIT + 200
    K = sp.diags([-np.ones(n - 1), 2.0 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1], format="csc") * 1e4
    M = sp.identity(n, format="csc")
    first = modes(M, K, count=10)
    sla.eigsh(sp.diags(np.arange(1.0, 301.0)), k=3)
    again = modes(M, K, count=10)
    assert np.array_equal(first.lam, again.lam) and np.array_equal(first.shapes, again.shapes)
    exact = 4e4 * np.sin(np.arange(1, 11) * np.pi / (2 * (n + 1))) ** 2  # the chain's closed form
    np.testing.assert_allclose(first.lam, exact, rtol=1e-9)
