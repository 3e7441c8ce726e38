"""Model updating from FRF residuals (identifier/updating/frf_residuals.py):
exact parameters from noise-free FRFs of a spring-mass chain and a wrong
prior, the analytic Jacobian against finite differences (dense and sparse,
damped and with the continuation's loss factor), coverage of the stated
standard errors under FRF noise, and the folder path from harmonic traces
through ``identify --method updating --option data=frf``."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from structbench.identifier.errors import IdentificationError
from structbench.identifier.updating import sensitivity, update_frf
from structbench.identifier.updating.frf_data import FrfData
from structbench.identifier.updating.frf_residuals import FrfResiduals, hold_factor
from structbench.identifier.updating.sensitivity import AffineModel
from structbench.models import Structure, load_model
from structbench.models.elements import PointMass, Spring
from structbench.models.structure import Element

sys.path.insert(0, str(Path(__file__).parent))
from identify_synth import harmonic_force, respond, write_trace  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "docs" / "examples" / "shear-frame-3.toml"
K = np.array([4.0e4, 3.0e4, 2.5e4])
M = np.array([10.0, 8.0, 6.0])


def chain(k: np.ndarray = K, m: np.ndarray = M, rayleigh: tuple[float, float] = (0.0, 0.0)) -> Structure:
    """A fixed-free chain of springs ``k`` and point masses ``m`` (x only)."""
    nodes = {i: np.array([0.0, 0.0, float(i)]) for i in range(len(k) + 1)}
    elements = [Element(Spring, (i - 1, i), {"k": float(k[i - 1])}, "x") for i in range(1, len(k) + 1)]
    elements += [Element(PointMass, (i,), {"m": float(m[i - 1])}, "x") for i in range(1, len(m) + 1)]
    return Structure("chain", nodes, elements, {0: ("x",)}, rayleigh, unknown=("mass", "stiffness"))


def closed_form(model: Structure, omega: np.ndarray, rows: list[int], force: int) -> np.ndarray:
    """Receptance ``[K - w^2 M + i w C]^-1`` at ``rows`` for a unit force at ``force`` (m, L)."""
    Kd, Md, Cd = (a.toarray() for a in (model.stiffness(), model.mass(), model.damping()))
    e = np.eye(model.n_dof)[:, force]
    return np.column_stack([np.linalg.solve(Kd - w**2 * Md + 1j * w * Cd, e)[rows] for w in omega])


def frf_data(model: Structure, omega: np.ndarray, rows: list[int], rel_std: float = 1e-3,
             noise: np.random.Generator | None = None) -> FrfData:
    """Receptances at ``rows`` for a force at the tip, standard error
    ``rel_std |H|`` per real and imaginary part; noise of that size if ``noise``."""
    H = closed_form(model, omega, rows, model.n_dof - 1)
    std = rel_std * np.abs(H)
    if noise is not None:
        H = H + std * (noise.standard_normal(H.shape) + 1j * noise.standard_normal(H.shape))
    L = omega.size
    return FrfData(omega, H, std, np.zeros(len(rows), int), [model.dofs[r] for r in rows],
                   [model.dofs[-1]] * L, np.zeros(L), np.zeros(L), np.zeros(L), "synthetic")


LINES = np.array([5.0, 20.0, 35.0, 50.0, 65.0, 80.0, 95.0, 110.0])  # rad/s, between and around the resonances


def scaled_prior(factors: np.ndarray) -> Structure:
    return chain(K * factors[3:], M * factors[:3])


def test_noise_free_frfs_give_the_parameters_from_a_prior_30_percent_off():
    truth = chain()
    data = frf_data(truth, LINES, [0, 2])
    prior = scaled_prior(np.array([1.3, 0.7, 1.3, 0.7, 1.3, 0.7]))
    result = update_frf(prior, data, regularisation="none")
    true = truth.values[truth.kind_mask()]
    np.testing.assert_allclose(result.values(), true, rtol=1e-7)
    assert result.details["identifiability"]["rank"] == 6  # the force fixes the common scale of M and K
    assert result.details["data"] == "frf" and result.details["frf"]["continuation"]  # undamped: continuation
    assert result.details["at_bound"] == []


def test_a_common_scale_of_mass_and_stiffness_is_found_from_frfs():
    truth = chain()
    prior = chain(1.25 * K, 1.25 * M)  # the same modes: modal data could not tell
    result = update_frf(prior, frf_data(truth, LINES, [2]), regularisation="none")
    np.testing.assert_allclose(result.values(), truth.values[truth.kind_mask()], rtol=1e-7)


@pytest.mark.parametrize("dense_limit", [400, 1])
@pytest.mark.parametrize("rayleigh,eta", [((0.0, 0.0), 0.0), ((0.5, 1e-4), 0.0), ((0.0, 0.0), 0.03)])
def test_analytic_jacobian_matches_finite_differences(monkeypatch, dense_limit, rayleigh, eta):
    monkeypatch.setattr(sensitivity, "DENSE_LIMIT", dense_limit)
    truth = chain(rayleigh=rayleigh)
    data = frf_data(truth, LINES, [0, 1])
    data.order = np.array([1, 2])                    # mobility and accelerance rows
    data.hold = np.full(LINES.size, 0.01)            # a held force
    data.gain = np.full(LINES.size, 0.005)           # errors common to a line
    prior = scaled_prior(np.array([1.1, 0.9, 1.05, 0.95, 1.1, 0.9]))
    prior = Structure(prior.name, prior.nodes, prior.elements, prior.supports, rayleigh, prior.unknown)
    sel = np.flatnonzero(prior.kind_mask())
    affine = AffineModel(prior, sel, np.array([0, 1]))
    assert affine.dense == (dense_limit == 400)
    C = prior.damping(prior.values)
    damping = None if C.nnz == 0 else (C.toarray() if affine.dense else C.tocsc())
    res = FrfResiduals(affine, data, np.full(LINES.size, 2), damping, eta)
    alpha = np.random.default_rng(1).normal(0.0, 0.05, sel.size)
    J = res(alpha).J
    step = 1e-6
    fd = np.column_stack([(res(alpha + step * e).r - res(alpha - step * e).r) / (2 * step) for e in np.eye(sel.size)])
    np.testing.assert_allclose(J, fd, rtol=1e-5, atol=1e-6 * np.abs(fd).max())
    for form in ("log",):  # the search stages' log-magnitude form
        log = res.with_eta(max(eta, 0.01), form)
        fd = np.column_stack([(log(alpha + step * e).r - log(alpha - step * e).r) / (2 * step)
                              for e in np.eye(sel.size)])
        np.testing.assert_allclose(log(alpha).J, fd, rtol=1e-5, atol=1e-6 * np.abs(fd).max())


def test_model_frf_is_the_closed_form_with_the_hold_and_the_quantity():
    truth = chain(rayleigh=(0.3, 2e-4))
    data = frf_data(truth, LINES, [0, 1, 2])
    data.order = np.array([0, 1, 2])
    data.hold = np.full(LINES.size, 0.02)
    sel = np.flatnonzero(truth.kind_mask())
    res = FrfResiduals(AffineModel(truth, sel, np.array([0, 1, 2])), data, np.full(LINES.size, 2),
                       truth.damping().toarray())
    expected = closed_form(truth, LINES, [0, 1, 2], 2) * (1j * LINES) ** np.array([0, 1, 2])[:, None] \
        * hold_factor(LINES, 0.02)[None, :]
    np.testing.assert_allclose(res.model_frf(np.zeros(sel.size)), expected, rtol=1e-12)


def test_stated_errors_cover_the_truth_under_frf_noise():
    """40 repetitions of 1 % complex FRF noise: the 95 % intervals of the 6
    parameters cover the truth within a binomial band of 95 % (240 estimates:
    +- 3 standard deviations, 0.908 .. 0.992)."""
    truth = chain()
    true = truth.values[truth.kind_mask()]
    prior = scaled_prior(np.array([1.2, 0.85, 1.1, 0.9, 1.15, 0.8]))
    rng = np.random.default_rng(7)
    inside = []
    for _ in range(40):
        result = update_frf(prior, frf_data(truth, LINES, [0, 2], rel_std=0.01, noise=rng))
        std = np.array([p.std_error for p in result.parameters])
        inside.append(np.abs(result.values() - true) <= 1.96 * std)
    coverage = float(np.mean(inside))
    band = 3 * np.sqrt(0.95 * 0.05 / np.size(inside))
    assert 0.95 - band <= coverage <= min(0.95 + band, 1.0), coverage


def _harmonic_folder(tmp_path: Path) -> tuple[Path, Path, Structure]:
    """Five harmonic tests of the damped 3-storey frame (force at the top,
    30 s, steady state after 20 s), displacement at every storey, and a prior
    TOML model with wrong storey stiffnesses."""
    truth = load_model(EXAMPLE)
    dt = 0.005
    t = np.arange(6000) * dt
    for i, w in enumerate([10.0, 30.0, 45.0, 62.0, 90.0]):
        response = respond(truth, harmonic_force(truth, 3, "x", 1000.0, w, t), dt)
        write_trace(tmp_path / "camp" / "traces" / f"sine-{i + 1:02d}.h5", truth, response, dt,
                    [("displacement", n, "x") for n in (1, 2, 3)], test=f"sine-{i + 1:02d}",
                    excitation_attrs={"kind": "harmonic", "omega": w, "window_start": 20.0})
    text = EXAMPLE.read_text().replace("k = 4.0e6", "k = 5.0e6").replace("k = 3.0e6", "k = 2.5e6")
    prior = tmp_path / "prior.toml"
    prior.write_text(text)
    return tmp_path / "camp", prior, truth


def test_folder_path_from_harmonic_traces_through_the_api(tmp_path):
    import structbench as sb

    folder, prior, truth = _harmonic_folder(tmp_path)
    doc = sb.identify(folder, "updating", model=prior, jobs=1, kinds="stiffness", joint=True)  # data=auto: frf
    run = doc["runs"][0]
    assert run["details"]["data"] == "frf" and run["details"]["frf"]["lines"] == 5
    assert run["details"]["frf"]["damping"] == "the prior's, not updated"
    true = truth.values[truth.kind_mask(("stiffness",))]
    np.testing.assert_allclose([p["value"] for p in run["parameters"]], true, rtol=1e-4)
    # both: the FRFs and a lab's modal data, each weighted by its stated errors
    found = truth.modes(3)
    shapes = found.shapes / np.abs(found.shapes).max(axis=0)
    lab = {"format": "structbench-modal-data", "format_version": 1, "dofs": [[1, "x"], [2, "x"], [3, "x"]],
           "modes": [{"omega": float(w), "omega_std": 1e-3 * float(w), "shape": s.tolist(), "shape_std": 0.01}
                     for w, s in zip(found.omega, shapes.T)]}
    (tmp_path / "lab.json").write_text(json.dumps(lab))
    doc = sb.identify(folder, "updating", model=prior, jobs=1, kinds="stiffness", joint=True, data="both",
                      modal=str(tmp_path / "lab.json"), tag="both")
    run = doc["runs"][0]
    assert run["details"]["data"] == "both" and run["details"]["modes"] == 3
    assert run["details"]["n_data"] == run["details"]["frf"]["n_data"] + 3 + 3 * 3
    np.testing.assert_allclose([p["value"] for p in run["parameters"]], true, rtol=1e-3)
    with pytest.raises(IdentificationError, match="needs identified modal data"):
        sb.identify(folder, "updating", model=prior, jobs=1, joint=True, data="modal")
    with pytest.raises(IdentificationError, match="data must be one of"):
        sb.identify(folder, "updating", model=prior, jobs=1, joint=True, data="nope")
