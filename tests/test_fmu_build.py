"""Building FMUs: valid model descriptions, naming convention, idempotence."""
from __future__ import annotations

import hashlib
import time
import zipfile
from pathlib import Path

import pytest
from fmpy import read_model_description
from fmpy.validation import validate_fmu
from fmu_fixtures import NAMES

from structbench.cli import main
from structbench.harness.fmu_session import fmu_checksum
from structbench.models import load_model
from structbench.fmus import build_fmu


@pytest.mark.parametrize("name", NAMES, ids=[Path(n).stem for n in NAMES])
def test_every_fmu_validates(fmus, name):
    assert validate_fmu(str(fmus[name])) == []


def test_variables_follow_the_naming_convention(fmus):
    md = read_model_description(str(fmus["ch3-free-free-beam"]))
    variables = {v.name: v for v in md.modelVariables}
    assert (variables["F_7_w"].causality, variables["F_7_w"].unit) == ("input", "N")
    assert variables["F_7_theta"].unit == "N.m"
    for prefix, units in (("u", ("m", "rad")), ("v", ("m/s", "rad/s")), ("a", ("m/s2", "rad/s2"))):
        assert variables[f"{prefix}_7_w"].causality == "output"
        assert (variables[f"{prefix}_7_w"].unit, variables[f"{prefix}_7_theta"].unit) == units
    assert variables["m_3"].start == "2.3" and variables["m_3"].unit == "kg/m"
    assert variables["k_3"].unit == "N/m" and variables["c_3"].unit == "N.s/m"
    assert variables["u0_7_theta"].variability == "fixed"
    assert sum(v.causality == "output" for v in md.modelVariables) == 96
    for v in md.modelVariables:
        assert v.unit and v.description, v.name
    assert "node 7" in variables["a_7_theta"].description and "theta" in variables["a_7_theta"].description

    membrane = {v.name for v in read_model_description(str(fmus["ch5-membrane"])).modelVariables}
    assert {"rho_5", "T_5", "c_5", "v0_5_w"} <= membrane
    modal = {v.name: v for v in read_model_description(str(fmus["ch5-simply-supported-beam"])).modelVariables}
    assert {"omega_15", "zeta_15", "q0_15", "qd0_15", "F_10_w", "a_10_w"} <= set(modal)
    assert "u0_1_w" not in modal and modal["omega_1"].unit == "rad/s"
    assert "x = 9.09091 m" in modal["u_10_w"].description


def test_resources_never_shadow_host_packages(fmus):
    modules = set()
    for path in fmus.values():
        with zipfile.ZipFile(path) as zf:
            top = {Path(n).parts[1].removesuffix(".py") for n in zf.namelist() if n.startswith("resources/")}
            module = zf.read("resources/slavemodule.txt").decode()
        assert not top & {"models", "bench", "identifier", "structbench"}
        assert module.startswith("sb_") and module not in modules
        modules.add(module)


def test_build_is_deterministic_and_idempotent(fmus, tmp_path):
    model = load_model("ch3-free-free-beam")
    first = build_fmu(model, tmp_path)
    assert fmu_checksum(first) == fmu_checksum(fmus["ch3-free-free-beam"])
    assert fmu_checksum(first) == hashlib.sha256(first.read_bytes()).hexdigest()
    stamp = first.stat().st_mtime_ns
    start = time.perf_counter()
    assert build_fmu(model, tmp_path) == first
    assert time.perf_counter() - start < 0.5 and first.stat().st_mtime_ns == stamp
    changed = build_fmu(model.with_values(model.values * 1.01), tmp_path)
    assert changed == first and changed.stat().st_mtime_ns != stamp


def test_build_fmus_command(tmp_path, capsys):
    assert main(["build-fmus", "ch4-cantilever-case1", "--out", str(tmp_path)]) == 0
    assert main(["build-fmus", "ch4-cantilever-case1", "--out", str(tmp_path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert "built" in lines[0] and "up to date" in lines[1]
    assert (tmp_path / "ch4-cantilever-case1.fmu").is_file()
    assert main(["build-fmus", "no-such-structure", "--out", str(tmp_path)]) == 2
