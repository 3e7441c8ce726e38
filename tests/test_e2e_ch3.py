"""Chapter 3 end to end: short variants of ``campaigns/ch3.toml`` run through
the FMU and the harness, identified from the trace files by ``structbench
identify --method least-squares``, scored against ``truth.json`` and gated
by ``structbench check`` with the campaign's own ``[check]`` table."""
from __future__ import annotations

import shutil
import tomllib
from pathlib import Path

import numpy as np
import pytest

from structbench.cli import main
from e2e_fixtures import CAMPAIGNS, derive, identify, run

# Table 3.4, actual natural frequencies of the beam (rad/s)
TABLE_3_4 = [0.0, 0.0, 0.064455, 0.206939, 0.408213, 0.719599, 1.096452, 1.524039, 1.999755, 2.575960]
# the dissertation's one noise realisation, recomputed (Tables 3.2, 3.3), and 1.5 x that
RMS_DISSERTATION = {4: 0.0284, 8: 0.0183}
RMS_MAX = {4: 0.043, 8: 0.027}
NOISE_FREE = {"harmonic": {"noise": None, "repetitions": None}}
REPETITIONS = 20


@pytest.fixture(scope="module")
def fmu_dir(fmus) -> Path:
    return fmus["ch3-free-free-beam"].parent


@pytest.fixture(scope="module")
def clean(tmp_path_factory, fmu_dir) -> Path:
    """The chapter 3 test without noise, once."""
    root = tmp_path_factory.mktemp("ch3-clean")
    return run(derive("ch3", root, NOISE_FREE), root / "out", fmu_dir)


@pytest.fixture(scope="module")
def noisy(tmp_path_factory, fmu_dir) -> tuple[Path, dict[int, dict]]:
    """2 % noise on accelerations and force, 20 repetitions; scores for m = 4, 8."""
    root = tmp_path_factory.mktemp("ch3-noisy")
    out = run(derive("ch3", root, {"harmonic": {"repetitions": REPETITIONS}}), root / "out", fmu_dir)
    return out, {m: identify(out, "least-squares", "--group", "harmonic", "--estimator", "ols",
                          "--samples", str(m), f"--tag=m{m}")
                 for m in (4, 8)}


@pytest.mark.parametrize("m", [4, 8])
def test_noise_free_recovers_all_30_parameters(clean, m):
    (result,) = identify(clean, "least-squares", "--samples", str(m), f"--tag=m{m}")["runs"]
    assert len(result["labels"]) == 30
    assert np.max(np.abs(result["errors"])) < 1e-6
    assert result["omega_true"] == pytest.approx(TABLE_3_4, rel=1e-5, abs=1e-9)


def test_noise_free_from_accelerations_integrated(clean):
    """The dissertation's set-up: velocities and displacements integrated from
    the 1 ms accelerations (zero-order-hold aware), not the logged ones."""
    (result,) = identify(clean, "least-squares", "--integration", "zoh-simpson", "--tag=integrated")["runs"]
    assert np.max(np.abs(result["errors"])) < 1e-6


def test_noisy_medians_meet_the_dissertation(noisy):
    _, scores = noisy
    rms = {m: scores[m]["summary"]["rms"]["median"] for m in (4, 8)}
    assert scores[4]["summary"]["runs"] == scores[8]["summary"]["runs"] == REPETITIONS
    assert rms[4] <= RMS_MAX[4] and rms[8] <= RMS_MAX[8]
    assert rms[8] < rms[4]


@pytest.mark.parametrize("m", [4, 8])
def test_noisy_identified_frequencies_within_one_percent(noisy, m):
    _, scores = noisy
    errors = np.abs([r["freq_error_pct"] for r in scores[m]["runs"]])  # % per run and mode
    assert errors.shape == (REPETITIONS, 10)
    assert np.all(np.median(errors, axis=0)[2:10] < 1.0)


def test_damped_beam_noise_free_recovers_all_45_parameters(tmp_path_factory, fmu_dir):
    root = tmp_path_factory.mktemp("ch3-damped")
    campaign = derive("ch3", root, NOISE_FREE, name="ch3-damped", structure="ch3-damped-beam")
    (result,) = identify(run(campaign, root / "out", fmu_dir), "least-squares", "--samples", "8")["runs"]
    assert len(result["labels"]) == 45
    assert {label.split("[")[0] for label in result["labels"]} == {"mass", "damping", "stiffness"}
    assert np.max(np.abs(result["errors"])) < 1e-6


def test_check_passes_with_the_campaigns_gates(noisy, capsys):
    folder, _ = noisy
    assert main(["check", str(folder)]) == 0
    lines = capsys.readouterr().out.splitlines()
    stems = {line.split()[1] for line in lines if line.startswith("PASS")}
    assert stems == {"least-squares-m4", "least-squares-m8"}
    assert lines[-1].endswith(" passed, 0 failed")


def test_check_fails_naming_the_violated_gate(noisy, tmp_path, capsys):
    """The same results against the campaign's gates plus one the spread over
    the seeds does not meet: 90 % of them within the dissertation's figure."""
    folder, scores = noisy
    gates = tomllib.loads((CAMPAIGNS / "ch3.toml").read_text())["check"]
    gates["least-squares-m4"] = gates["least-squares-m4"] | {"rms_p90_max": RMS_DISSERTATION[4]}
    strict = tmp_path / "strict"
    derive("ch3", strict, {"harmonic": {"repetitions": REPETITIONS}}, check=gates).rename(strict / "campaign.toml")
    shutil.copy(folder / "truth.json", strict)
    shutil.copytree(folder / "results", strict / "results")
    assert main(["check", str(strict)]) == 1
    lines = capsys.readouterr().out.splitlines()
    failed = [line.split() for line in lines if line.startswith("FAIL")]
    assert [row[1:4] for row in failed] == [["least-squares-m4", "rms_p90_max",
                                             f"{scores[4]['summary']['rms']['p90']:.4g}"]]
    assert "(threshold 0.0284)" in " ".join(failed[0]) and lines[-1].endswith(" passed, 1 failed")
