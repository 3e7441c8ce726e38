"""Layout criteria of ``structbench plan``: the frequency-targeted layout
against D-optimal and an exhaustive search; the ``--criterion`` option."""
from __future__ import annotations

import itertools
import json
import warnings
from pathlib import Path

import numpy as np
import pytest

import structbench as sb
from structbench.cli.main import main
from structbench.planning import free_decay as fd
from structbench.planning import layouts


def small_beam(folder: Path, elements: int = 6) -> Path:
    """A damped simply supported beam (L = 10 m, m = 1 kg/m, EI = 1 N m^2),
    a free decay after an impulse at node 2, and every DOF as a candidate
    displacement channel (12 for 6 elements)."""
    lines = [f'name = "beam{elements}"', "rayleigh = [0.004, 0.004]"]
    lines += [f"[[nodes]]\nid = {i + 1}\nx = {i * 10 / elements!r}" for i in range(elements + 1)]
    lines += [f'[[elements]]\ntype = "beam"\nnodes = [{i + 1}, {i + 2}]\nm = 1.0\nk = {(elements / 10) ** 3!r}'
              for i in range(elements)]
    lines += ['[[supports]]\nnode = 1\nfix = ["w"]', f'[[supports]]\nnode = {elements + 1}\nfix = ["w"]']
    (folder / "beam.toml").write_text("\n".join(lines) + "\n")
    (folder / "c.toml").write_text("""structure = "beam.toml"
[[tests]]
name = "knock"
dt = 0.05
duration = 300.0
noise = {sensor = 0.02}
[[tests.excitation]]
kind = "impulse"
node = 2
dir = "w"
impulse = 1.0
method = "initial-velocity"
[[tests.sensors]]
nodes = [2]
dirs = ["w"]
quantities = ["displacement"]
""")
    (folder / "cand.toml").write_text('[[candidates]]\nnodes = "all"\nquantities = ["displacement"]\n')
    return folder / "c.toml"


def relative_variance(doc: dict, omegas: list[float]) -> float:
    """Summed var(omega) / omega^2 of the plan's ``modes`` (computed from the
    written layout campaign) over the modes ``omegas`` (rad/s)."""
    found = {round(m["omega"], 6): m["predicted_omega_std"] / m["omega"] for m in doc["modes"]}
    return float(sum(found[round(w, 6)] ** 2 for w in omegas))


def test_targeted_layout_is_the_exhaustive_optimum(tmp_path: Path) -> None:
    """3 of 12 candidates: every one of the 220 layouts evaluated through the
    bound (``omega_zeta_covariance`` of the summed information, no ridge);
    the frequencies layout is the global minimum of the summed relative
    frequency variance and below D-optimal's (1.48 times above it here);
    the plan's own bound of the written layout agrees."""
    campaign = small_beam(tmp_path)
    freq = sb.plan(campaign, "modal", candidates=tmp_path / "cand.toml", sensors=3,
                   layout_out=tmp_path / "f.toml", criterion="frequencies")
    dopt = sb.plan(campaign, "modal", candidates=tmp_path / "cand.toml", sensors=3,
                   layout_out=tmp_path / "d.toml", criterion="d-optimal")
    assert freq["layout"]["criterion"] == "frequencies" and dopt["layout"]["criterion"] == "d-optimal"
    loaded = sb.load_campaign(campaign)
    cands = layouts.read_candidates(tmp_path / "cand.toml", loaded.model)
    info, _, d = layouts.candidate_information(loaded.model, loaded.tests[0], cands)
    scale = np.repeat(d.omega, 2)
    values = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for subset in itertools.combinations(range(len(cands)), 3):
            J = info[list(subset)].sum(axis=0) / np.outer(scale, scale)
            if np.linalg.eigvalsh(J / np.sqrt(np.outer(np.diag(J), np.diag(J))))[0] < 1e-12:
                continue  # a layout that does not determine every planned mode
            cov = fd.omega_zeta_covariance(d, J)
            values[tuple(sorted(cands[i] for i in subset))] = float(np.sum(cov[:, 0, 0] / d.omega**2))
    best = min(values.values())
    key = {name: tuple(sorted(tuple(s) for s in doc["layout"]["sensors"])) for name, doc in
           (("frequencies", freq), ("d-optimal", dopt))}
    assert values[key["frequencies"]] == pytest.approx(best, rel=1e-6)
    assert values[key["d-optimal"]] > 1.2 * best
    planned = freq["layout"]["modes_planned"]
    assert relative_variance(freq, planned) == pytest.approx(best, rel=1e-3)
    assert relative_variance(dopt, planned) == pytest.approx(values[key["d-optimal"]], rel=1e-3)
    row = freq["layout"]["layouts"]["frequencies"]
    assert row["rms_rel_omega_std"] == pytest.approx(np.sqrt(best / len(planned)), rel=1e-3)


def test_criterion_option_cli_json(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """``--criterion`` and ``--target-modes`` on the command line: the JSON
    records them, the chosen layout is the criterion's best row, the table
    names the criterion; a bad target count is a user error (status 2)."""
    campaign = small_beam(tmp_path)
    base = ["plan", str(campaign), "--method", "modal", "--candidates", str(tmp_path / "cand.toml"),
            "--sensors", "4", "--layout-out", str(tmp_path / "lay.toml")]
    assert main(base + ["--criterion", "d-optimal", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)["layout"]
    assert doc["criterion"] == "d-optimal" and set(doc["layouts"]) == {"frequencies", "d-optimal",
                                                                       "effective-independence"}
    assert doc["chosen"] == max(doc["layouts"], key=lambda n: doc["layouts"][n]["log_det"])
    assert main(base + ["--target-modes", "3", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)["layout"]
    assert doc["criterion"] == "frequencies" and len(doc["target_modes"]) == 3
    assert doc["target_modes"] == doc["modes_planned"][:3]
    assert doc["chosen"] == min(doc["layouts"], key=lambda n: doc["layouts"][n]["rms_rel_omega_std"])
    written = sb.load_campaign(tmp_path / "lay.toml")
    assert sorted(c.name for c in written.tests[0].channels) == sorted(f"{q}_{n}_{d}" for n, d, q in doc["sensors"])
    assert main(base + ["--criterion", "effective-independence"]) == 0
    assert "by criterion effective-independence" in capsys.readouterr().out
    assert main(base + ["--target-modes", "0"]) == 2
    assert "--target-modes" in capsys.readouterr().err
