"""Model updating from modal data (identifier/updating): exact answers from
noise-free data, the analytic Jacobian against finite differences (dense and
sparse paths), the SMU 18-DOF protocol on a few starts, the ill-posed
identifiability report, a short coverage profile, the folder path through
the API and the error without modal data."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import norm

from structbench.identifier.errors import IdentificationError
from structbench.identifier.updating import ModalData, sensitivity, update
from structbench.identifier.updating.data import from_document
from structbench.identifier.updating.residuals import Residuals
from structbench.models import Structure, load_model
from structbench.models.elements import PointMass, Spring
from structbench.models.structure import Element

sys.path.insert(0, str(Path(__file__).parent))
from identify_synth import respond, write_trace  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "docs" / "examples" / "shear-frame-3.toml"
K_SMU = np.array([1155, 1092, 1073, 1028, 1028, 990, 963, 938, 876, 840, 824, 788, 712, 660, 619, 562, 491,
                  363]) * 1e5
W_SMU = np.array([208] * 11 + [206] * 6 + [202]) * 1e3
ALPHA_SMU = np.array([0.05, 0.05, -0.05, -0.10, 0.10, -0.15, 0.15, 0.25, -0.10, 0.20, 0.30, 0.25, -0.15, 0.05,
                      -0.15, 0.10, 0.20, 0.20])


def smu_frame(k: np.ndarray) -> Structure:
    """The SMU 18-storey shear frame (springs first: stiffness[j] is k_j)."""
    nodes = {i: np.array([0.0, 0.0, 3.0 * i]) for i in range(19)}
    elements = [Element(Spring, (i - 1, i), {"k": float(k[i - 1])}, "x") for i in range(1, 19)]
    elements += [Element(PointMass, (i,), {"m": W_SMU[i - 1] / 9.8}, "x") for i in range(1, 19)]
    return Structure("smu-18", nodes, elements, {0: ("x",)}, unknown=("stiffness",))


def modal_data(truth: Structure, modes: int, dofs: list[tuple[int, str]], noise: float = 0.0,
               rng: np.random.Generator | None = None) -> ModalData:
    found = truth.modes(modes)
    shapes = found.shapes[[truth.dof_index(*d) for d in dofs]]
    shapes = shapes / shapes[np.argmax(np.abs(shapes), axis=0), np.arange(modes)]
    lam, std = found.lam.copy(), np.nan
    if noise:
        lam = lam * (1 + noise * rng.standard_normal(modes))
        shapes = shapes + noise * rng.standard_normal(shapes.shape)
        std = noise
    return ModalData(lam, std * lam, shapes, np.full(shapes.shape, std), list(dofs), "test")


def scaled(model: Structure, factors: dict[str, float]) -> Structure:
    p = model.values.copy()
    for i, par in enumerate(model.parameters):
        p[i] *= factors.get(par.label, 1.0)
    return model.with_values(p)


def test_small_shear_frame_noise_free_gives_the_true_stiffnesses():
    truth = load_model(EXAMPLE)
    prior = scaled(truth, {"stiffness[4]": 1.3, "stiffness[5]": 0.8, "stiffness[6]": 1.15})
    data = modal_data(truth, 3, [(1, "x"), (2, "x"), (3, "x")])
    result = update(prior, data, kinds="stiffness")
    assert result.status == "converged"
    assert [p.label for p in result.parameters] == ["stiffness[4]", "stiffness[5]", "stiffness[6]"]
    true = truth.values[truth.kind_mask(("stiffness",))]
    np.testing.assert_allclose(result.values(), true, rtol=1e-6)
    assert [p.initial for p in result.parameters] == pytest.approx(prior.values[prior.kind_mask(("stiffness",))])
    assert result.details["weights"] == {"eigenvalues": "unit (no standard errors stated)",
                                         "shapes": "unit (no standard errors stated)"}
    assert result.details["identifiability"]["rank"] == 3 and result.details["at_bound"] == []
    np.testing.assert_allclose(result.omega, truth.modes(3).omega, rtol=1e-8)


def test_mass_and_stiffness_together_report_the_scale_they_cannot_separate():
    """Eigenvalues and unscaled shapes fix K and M only up to a common factor:
    one undetermined combination, left at the prior."""
    truth = load_model(EXAMPLE)
    data = modal_data(truth, 3, [(1, "x"), (2, "x"), (3, "x")])
    result = update(scaled(truth, {"stiffness[5]": 0.9}), data)
    report = result.details["identifiability"]
    assert report["rank"] == 5 and len(report["undetermined"]) == 1
    vector = np.array(report["undetermined"][0]["vector"])
    assert np.all(np.abs(vector) > 0.3)   # every mass and stiffness, same sign: a common scale
    assert np.all(np.sign(vector) == np.sign(vector[0]))
    assert abs(vector @ np.array(result.details["alpha"])) < 1e-6
    assert all(p.std_error is None for p in result.parameters)


@pytest.mark.parametrize("dense_limit", [400, 4])
@pytest.mark.parametrize("scaling", ["least-squares", "entry"])
def test_analytic_jacobian_matches_finite_differences(monkeypatch, dense_limit, scaling):
    monkeypatch.setattr(sensitivity, "DENSE_LIMIT", dense_limit)
    truth = smu_frame(K_SMU * (1 + ALPHA_SMU))
    data = modal_data(truth, 3, [(1, "x"), (5, "x"), (9, "x"), (14, "x"), (18, "x")])
    data.lam_std[:] = 0.02 * data.lam
    data.shape_std[:] = 0.05
    model = smu_frame(K_SMU)
    sel = np.flatnonzero(model.kind_mask(("mass", "stiffness")))
    affine = sensitivity.AffineModel(model, sel, np.array([model.dof_index(*d) for d in data.dofs]))
    res = Residuals(affine, data, scaling)
    x = np.random.default_rng(3).uniform(-0.2, 0.2, sel.size)
    ev = res(x)
    res.fix_pairs(ev.pairs)
    def r(y: np.ndarray) -> np.ndarray:  # modes solved afresh (not warm-started) for clean differences
        affine._basis = None
        return res(y).r

    h = 1e-6
    fd = np.column_stack([(r(x + h * e) - r(x - h * e)) / (2 * h) for e in np.eye(sel.size)])
    np.testing.assert_allclose(ev.J, fd, rtol=1e-5, atol=1e-6 * np.abs(fd).max())


def test_smu_protocol_random_starts_reach_the_truth():
    prior = smu_frame(K_SMU)
    data = modal_data(smu_frame(K_SMU * (1 + ALPHA_SMU)), 4, [(d, "x") for d in (1, 4, 7, 9, 12, 15, 18)])
    rng = np.random.default_rng(7)
    for _ in range(10):
        result = update(prior, data, bounds=(-1, 1), x0=[rng.uniform(-1, 1, 18)])
        assert np.mean(np.abs(result.values() / (K_SMU * (1 + ALPHA_SMU)) - 1)) < 1e-3


def test_sparse_path_gives_the_dense_answer(monkeypatch):
    prior = smu_frame(K_SMU)
    data = modal_data(smu_frame(K_SMU * (1 + ALPHA_SMU)), 4, [(d, "x") for d in (1, 4, 7, 9, 12, 15, 18)])
    dense = update(prior, data, bounds=(-1, 1))
    monkeypatch.setattr(sensitivity, "DENSE_LIMIT", 4)
    sparse = update(prior, data, bounds=(-1, 1))
    np.testing.assert_allclose(sparse.values(), dense.values(), rtol=1e-6)


def test_ill_posed_update_reports_the_undetermined_combinations_and_stays_off_the_bounds():
    truth = 0.5 * ALPHA_SMU
    data = modal_data(smu_frame(K_SMU * (1 + truth)), 2, [(d, "x") for d in (3, 6, 9, 12, 15, 18)])
    result = update(smu_frame(K_SMU), data, bounds=(-0.3, 0.3))
    report = result.details["identifiability"]
    assert report["rank"] == 12 and report["parameters"] == 18
    assert len(report["undetermined"]) == 6
    assert all(len(c["components"]) == 4 and c["components"][0]["label"].startswith("stiffness[")
               for c in report["undetermined"])
    null = np.array([c["vector"] for c in report["undetermined"]])
    alpha = np.array(result.details["alpha"])
    assert np.linalg.norm(null @ alpha) < 1e-4 < 0.1 < np.linalg.norm(null @ truth)
    assert result.details["at_bound"] == [] and np.max(np.abs(alpha)) < 0.29
    assert result.details["misfit"] < 1e-12
    assert "GCV needs residual degrees of freedom" in result.details["regularisation"]["reason"]


def test_ill_posed_update_with_stated_noise_is_regularised_off_the_bounds():
    """The same 12 data with 1 % noise, stated: unregularised, noise drives
    weakly determined combinations onto the bounds (the reference package's
    990 of 1,000 starts); the discrepancy rule keeps every parameter inside."""
    truth = 0.5 * ALPHA_SMU
    for seed in range(3):
        data = modal_data(smu_frame(K_SMU * (1 + truth)), 2, [(d, "x") for d in (3, 6, 9, 12, 15, 18)],
                          noise=0.01, rng=np.random.default_rng(seed))
        result = update(smu_frame(K_SMU), data, bounds=(-0.3, 0.3))
        assert result.details["regularisation"]["rule"] == "discrepancy"
        assert result.details["regularisation"]["weight"] > 1.0
        assert result.details["at_bound"] == []
        assert np.sqrt(np.mean((np.array(result.details["alpha"]) - truth) ** 2)) < 0.1
    loose = update(smu_frame(K_SMU), data, bounds=(-0.3, 0.3), regularisation="none")
    assert len(loose.details["at_bound"]) >= 3


def test_stated_errors_cover_the_truth_under_noise():
    """1 % noise on eigenvalues and shapes, stated: the discrepancy principle
    and Fisher-based intervals (short profile of benchmarks/updating_smu.py)."""
    prior, true = smu_frame(K_SMU), K_SMU * (1 + ALPHA_SMU)
    dofs = [(d, "x") for d in (1, 4, 7, 9, 12, 15, 18)]
    inside = []
    for seed in range(30):
        data = modal_data(smu_frame(true), 4, dofs, noise=0.01, rng=np.random.default_rng(seed))
        result = update(prior, data, bounds=(-1, 1))
        assert result.details["regularisation"]["rule"] == "discrepancy"
        assert result.details["weights"]["shapes"] == "stated standard errors"
        std = np.array([p.std_error for p in result.parameters], dtype=float)
        inside.append(np.abs(result.values() - true) <= norm.ppf(0.975) * std)
    assert 0.85 <= np.mean(inside) <= 0.99


def test_without_stated_errors_the_weight_comes_from_gcv_and_errors_from_the_sandwich():
    prior, true = smu_frame(K_SMU), K_SMU * (1 + ALPHA_SMU)
    data = modal_data(smu_frame(true), 4, [(d, "x") for d in (1, 4, 7, 9, 12, 15, 18)], noise=0.01,
                      rng=np.random.default_rng(0))
    data.lam_std[:] = np.nan
    data.shape_std[:] = np.nan
    result = update(prior, data, bounds=(-1, 1))
    assert result.details["regularisation"]["rule"] == "gcv"
    assert result.details["std_errors"].startswith("sandwich")
    assert all(p.std_error is not None and p.std_error > 0 for p in result.parameters)


def test_modal_data_document_is_read_with_its_errors():
    doc = {"format": "structbench-modal-data", "format_version": 1, "dofs": [[1, "x"], [2, "x"]],
           "modes": [{"omega": 10.0, "omega_std": 0.1, "shape": [0.5, 1.0], "shape_std": 0.01},
                     {"omega": 25.0}]}
    data = from_document(doc)
    np.testing.assert_allclose(data.lam, [100.0, 625.0])
    np.testing.assert_allclose(data.lam_std[0], 2.0)
    assert np.isnan(data.lam_std[1]) and np.all(np.isnan(data.shapes[:, 1]))
    np.testing.assert_allclose(data.shape_std[:, 0], 0.01)
    with pytest.raises(IdentificationError, match="shape"):
        from_document(doc | {"modes": [{"omega": 10.0, "shape": [1.0]}]})
    with pytest.raises(IdentificationError, match="format"):
        from_document({"modes": []})


def _folder(tmp_path: Path) -> tuple[Path, Path, Structure]:
    """A campaign folder with one short random-force trace of the 3-storey
    frame, and a prior TOML model with wrong storey stiffnesses."""
    truth = load_model(EXAMPLE)
    force = np.zeros((200, truth.n_dof))
    force[:, 2] = np.random.default_rng(0).standard_normal(200)
    write_trace(tmp_path / "camp" / "traces" / "random-r0.h5", truth, respond(truth, force, 0.01), 0.01,
                [("displacement", n, "x") for n in (1, 2, 3)] + [("force", 3, "x")], test="random",
                excitation_attrs={"kind": "random"})
    text = EXAMPLE.read_text().replace("k = 4.0e6", "k = 5.0e6").replace("k = 3.0e6", "k = 2.5e6")
    prior = tmp_path / "prior.toml"
    prior.write_text(text)
    return tmp_path / "camp", prior, truth


def test_folder_path_through_the_api_with_modal_results(tmp_path):
    import structbench as sb

    folder, prior, truth = _folder(tmp_path)
    found = truth.modes(3)
    shapes = found.shapes / np.abs(found.shapes).max(axis=0)
    modal = {"format": "structbench-result", "format_version": 1, "method": "modal",
             "runs": [{"repetition": 0, "tests": ["random"], "omega": found.omega.tolist(),
                       "omega_std": (1e-3 * found.omega).tolist(), "mode_shapes": shapes.T.tolist(),
                       "sensors": ["displacement_1_x", "displacement_2_x", "displacement_3_x"],
                       "details": {"quantity": "displacement"}}]}
    (folder / "results").mkdir()
    (folder / "results" / "modal.json").write_text(json.dumps(modal))
    doc = sb.identify(folder, "updating", model=prior, jobs=1, kinds="stiffness")
    run = doc["runs"][0]
    assert doc["method"] == "updating" and run["tests"] == ["random"]
    true = truth.values[truth.kind_mask(("stiffness",))]
    np.testing.assert_allclose([p["value"] for p in run["parameters"]], true, rtol=1e-6)
    assert run["details"]["weights"] == {"eigenvalues": "stated standard errors",
                                         "shapes": "unit (no standard errors stated)"}
    assert (folder / "results" / "updating.json").is_file()
    # the same modes as a modal-data file a lab hands over, named by --option modal=
    lab = {"format": "structbench-modal-data", "format_version": 1, "dofs": [[1, "x"], [2, "x"], [3, "x"]],
           "modes": [{"omega": float(w), "shape": s.tolist()} for w, s in zip(found.omega, shapes.T)]}
    (tmp_path / "lab.json").write_text(json.dumps(lab))
    doc = sb.identify(folder, "updating", model=prior, jobs=1, kinds="stiffness", modal=str(tmp_path / "lab.json"),
                      tag="lab")
    np.testing.assert_allclose([p["value"] for p in doc["runs"][0]["parameters"]], true, rtol=1e-6)


def test_no_modal_data_is_a_clear_error(tmp_path):
    import structbench as sb

    folder, prior, _ = _folder(tmp_path)
    with pytest.raises(IdentificationError, match=r"needs identified modal data: --option modal=FILE") as err:
        sb.identify(folder, "updating", model=prior, jobs=1, data="modal")  # data=auto: FRFs of the force
    assert "modal-data-format.md" in str(err.value) and "--method modal" in str(err.value)
    assert not (folder / "results" / "updating.json").exists()
    with pytest.raises(IdentificationError, match="no modal data file 'missing.json'"):
        sb.identify(folder, "updating", model=prior, jobs=1, modal="missing.json")
