"""Element matrices against closed forms; the assembly is affine in the parameters."""
import numpy as np
import pytest

from structbench.models import load_model
from structbench.models.elements import Beam, Dashpot, PointMass, Spring, Tri3Membrane


def test_beam_matrices_are_the_hermite_closed_forms():
    h = 2.0
    pats = Beam.patterns(np.array([[0.0, 0.0], [h, 0.0]]))
    # consistent mass m h / 420 [...] with m = 1: total translational mass is h
    rigid = np.array([1.0, 0.0, 1.0, 0.0])
    assert rigid @ pats["m"] @ rigid == pytest.approx(h)
    assert pats["m"][0, 0] == pytest.approx(156 * h / 420)
    assert pats["m"][1, 3] == pytest.approx(-3 * h**3 / 420)
    assert pats["k"][1, 1] == pytest.approx(4 * h**2)
    assert pats["k"][0, 3] == pytest.approx(6 * h)
    # rigid translation and rotation are strain-free
    rotation = np.array([-h / 2, 1.0, h / 2, 1.0])
    np.testing.assert_allclose(pats["k"] @ rigid, 0, atol=1e-12)
    np.testing.assert_allclose(pats["k"] @ rotation, 0, atol=1e-12)
    # a constant curvature w = x^2/2 stores strain energy EI/2 * L * 1 = k h^3 h / 2
    curvature = np.array([0.0, 0.0, h**2 / 2, h])
    assert 0.5 * curvature @ pats["k"] @ curvature == pytest.approx(0.5 * h**3 * h)
    np.testing.assert_array_equal(pats["c"], pats["k"])


def test_tri3_matrices_of_a_right_triangle():
    pats = Tri3Membrane.patterns(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]))
    expected_k = 0.5 * np.array([[2.0, -1.0, -1.0], [-1.0, 1.0, 0.0], [-1.0, 0.0, 1.0]])
    np.testing.assert_allclose(pats["T"], expected_k, atol=1e-15)
    np.testing.assert_allclose(pats["rho"], 0.5 / 12 * np.array([[2, 1, 1], [1, 2, 1], [1, 1, 2]]))
    assert pats["rho"].sum() == pytest.approx(0.5)  # total mass = area x density


def test_lumped_elements():
    two = np.zeros((2, 3))
    np.testing.assert_array_equal(Spring.patterns(two)["k"], [[1, -1], [-1, 1]])
    np.testing.assert_array_equal(Dashpot.patterns(two[:1])["c"], [[1]])
    np.testing.assert_array_equal(PointMass.patterns(two[:1])["m"], [[1]])


@pytest.mark.parametrize("name", ["ch3-damped-beam", "ch4-cantilever-case1", "ch5-membrane",
                                  "docs/examples/shear-frame-3.toml"])
def test_derivative_matrices_match_finite_differences(name):
    model = load_model(name)
    p = model.values
    rng = np.random.default_rng(1)
    assemble = {"mass": model.mass, "damping": model.damping, "stiffness": model.stiffness}
    for j in rng.choice(len(p), size=min(len(p), 8), replace=False):
        par = model.parameters[j]
        step = 1e-3 * max(abs(p[j]), 1.0)
        up, down = p.copy(), p.copy()
        up[j] += step
        down[j] -= step
        fd = (assemble[par.kind](up) - assemble[par.kind](down)).toarray() / (2 * step)
        np.testing.assert_allclose(model.derivatives[j].toarray(), fd, atol=1e-9)
    # affine: each matrix is the sum of parameter times derivative
    for kind, fn in assemble.items():
        total = np.zeros((model.n_dof, model.n_dof))
        for v, d, q in zip(p, model.derivatives, model.parameters):
            if q.kind == kind:
                total += v * d.toarray()
        np.testing.assert_allclose(fn().toarray(), total, atol=1e-12)
