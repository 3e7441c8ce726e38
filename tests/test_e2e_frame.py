"""Another structure end to end: a 3-storey shear frame packaged as an FMU of
the test's own (pythonfmu, its own variable names, not built from
``models/``), run through a campaign mapping, identified from the TOML model
``docs/examples/shear-frame-3.toml`` and scored against the campaign's truth."""
from __future__ import annotations

import json
import tomllib
from pathlib import Path

import h5py
import numpy as np
import pytest

from structbench.harness.external import fmu_variables
from e2e_fixtures import identify, run, toml_text
from structbench.models import load_model

SHEAR_FRAME = Path(__file__).resolve().parents[1] / "docs" / "examples" / "shear-frame-3.toml"

FRAME_SLAVE = '''
"""Floors 1..3 moving along x, storey i (spring Frame.k{i}, dashpot Frame.c{i})
between floor i - 1 (0: ground) and floor i. Exact for forces held over a
step: the matrix exponential of the augmented state-space system."""
import numpy as np
import scipy.linalg as la
from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real

FLOORS = 3


class ShearFrame(Fmi2Slave):
    author = "structbench tests"
    description = "3-storey lumped shear frame"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.par = {f"Frame.{p}{i}": v for p, v in (("m", 1000.0), ("k", 1.0e6), ("c", 1.0e3))
                    for i in range(1, FLOORS + 1)}
        self.f, self.v0 = np.zeros(FLOORS), np.zeros(FLOORS)
        self.u, self.v = np.zeros(FLOORS), np.zeros(FLOORS)
        self.cache = {}
        for name in self.par:
            self.register_variable(Real(name, causality=Fmi2Causality.parameter,
                                        variability=Fmi2Variability.tunable,
                                        getter=lambda n=name: self.par[n],
                                        setter=lambda x, n=name: self.par.__setitem__(n, x)))
        for i in range(FLOORS):
            floor = f"Frame.Floor{i + 1}"
            self.register_variable(Real(f"{floor}.Fx", causality=Fmi2Causality.input,
                                        getter=lambda i=i: float(self.f[i]),
                                        setter=lambda x, i=i: self.f.__setitem__(i, x)))
            self.register_variable(Real(f"{floor}.vx0", causality=Fmi2Causality.parameter,
                                        variability=Fmi2Variability.fixed,
                                        getter=lambda i=i: float(self.v0[i]),
                                        setter=lambda x, i=i: self.v0.__setitem__(i, x)))
            self.register_variable(Real(f"{floor}.x", causality=Fmi2Causality.output,
                                        getter=lambda i=i: float(self.u[i])))
            self.register_variable(Real(f"{floor}.vx", causality=Fmi2Causality.output,
                                        getter=lambda i=i: float(self.v[i])))
            self.register_variable(Real(f"{floor}.ax", causality=Fmi2Causality.output,
                                        getter=lambda i=i: float(self.acceleration()[i])))

    def matrices(self):
        m = np.diag([self.par[f"Frame.m{i}"] for i in range(1, FLOORS + 1)])
        k, c = np.zeros((FLOORS, FLOORS)), np.zeros((FLOORS, FLOORS))
        for i in range(FLOORS):
            for mat, name in ((k, "k"), (c, "c")):
                value = self.par[f"Frame.{name}{i + 1}"]
                mat[i, i] += value
                if i > 0:
                    mat[i - 1, i - 1] += value
                    mat[i, i - 1] -= value
                    mat[i - 1, i] -= value
        return m, c, k

    def acceleration(self):
        m, c, k = self.matrices()
        return np.linalg.solve(m, self.f - c @ self.v - k @ self.u)

    def exit_initialization_mode(self):
        self.u, self.v = np.zeros(FLOORS), self.v0.copy()

    def do_step(self, current_time, step_size):
        key = (tuple(self.par.values()), step_size)
        if key not in self.cache:
            m, c, k = self.matrices()
            n = FLOORS
            a = np.zeros((3 * n, 3 * n))
            a[:n, n:2 * n] = np.eye(n)
            a[n:2 * n, :n] = -np.linalg.solve(m, k)
            a[n:2 * n, n:2 * n] = -np.linalg.solve(m, c)
            a[n:2 * n, 2 * n:] = np.linalg.inv(m)
            e = la.expm(a * step_size)
            self.cache = {key: (e[:2 * n, :2 * n], e[:2 * n, 2 * n:])}
        ad, bd = self.cache[key]
        x = ad @ np.concatenate([self.u, self.v]) + bd @ self.f
        self.u, self.v = x[:FLOORS], x[FLOORS:]
        return True
'''


def frame_parameters() -> dict[str, float]:
    """The FMU's parameters with the TOML model's values: ``Frame.m{floor}``,
    ``Frame.k{storey}``, ``Frame.c{storey}`` (storey i ends at floor i)."""
    names = {"mass": "m", "spring": "k", "dashpot": "c"}
    out = {}
    for element in tomllib.loads(SHEAR_FRAME.read_text())["elements"]:
        name = names[element["type"]]
        out[f"Frame.{name}{element['nodes'][-1]}"] = element[name]
    return out


def campaign(model) -> dict:
    """A forced test (two harmonics at the top floor) and a free response
    (initial velocity of the top floor), mapped onto the frame's variables."""
    sensors = [{"nodes": "all", "dirs": ["x"], "quantities": ["displacement", "velocity", "acceleration"]}]
    return {
        "name": "shear-frame", "structure": "ShearFrame.fmu", "seed": 7,
        "parameters": frame_parameters(),
        "mapping": {"force": "Frame.Floor{node}.F{dir}", "displacement": "Frame.Floor{node}.{dir}",
                    "velocity": "Frame.Floor{node}.v{dir}", "acceleration": "Frame.Floor{node}.a{dir}",
                    "initial_velocity": "Frame.Floor{node}.v{dir}0"},
        "locations": {str(n): [0.0, 0.0, 3.0 * n] for n in (1, 2, 3)},
        "truth": {"parameters": [{"label": p.label, "value": float(v)}
                                 for p, v in zip(model.parameters, model.values)],
                  "omega": model.modes().omega.tolist()},
        "tests": [
            {"name": "forced", "dt": 0.001, "duration": 2.0,
             "excitation": [{"kind": "harmonic", "node": 3, "dir": "x", "amplitude": 1000.0, "omega": w}
                            for w in (15.0, 40.0)],
             "sensors": sensors + [{"nodes": [3], "dirs": ["x"], "quantities": ["force"]}]},
            {"name": "free", "dt": 0.001, "duration": 10.0,
             "excitation": [{"kind": "initial", "node": 3, "dir": "x", "velocity": 1.0}],
             "sensors": [{"nodes": "all", "dirs": ["x"], "quantities": ["displacement", "velocity"]}]},
        ]}


@pytest.fixture(scope="module")
def model():
    return load_model(SHEAR_FRAME)


@pytest.fixture(scope="module")
def frame(tmp_path_factory, model) -> Path:
    """The campaign folder of the frame, run through its FMU."""
    from pythonfmu.builder import FmuBuilder

    root = tmp_path_factory.mktemp("frame")
    script = root / "shear_frame_test_slave.py"
    script.write_text(FRAME_SLAVE)
    FmuBuilder.build_FMU(script, dest=root)
    path = root / "shear-frame.toml"
    path.write_text(toml_text(campaign(model)))
    return run(path, root / "out")


def test_the_fmu_speaks_its_own_names(frame):
    """The FMU has none of structbench's names; the traces have the harness's
    channel names; the truth is the campaign's."""
    variables = fmu_variables(json.loads((frame / "status.json").read_text())["fmu"])
    assert {"Frame.Floor3.Fx", "Frame.Floor3.x", "Frame.Floor3.vx", "Frame.Floor3.ax", "Frame.k3"} <= set(variables)
    assert not {"F_3_x", "u_3_x", "a_3_x", "k_6"} & set(variables)
    with h5py.File(frame / "traces" / "forced.h5", "r") as f:
        assert f.attrs["structure"] == "ShearFrame"
        assert set(f["channels"]) == {f"{q}_{n}_x" for q in ("displacement", "velocity", "acceleration")
                                      for n in (1, 2, 3)} | {"force_3_x"}
    truth = json.loads((frame / "truth.json").read_text())
    assert truth["source"] == "campaign" and len(truth["parameters"]) == 9


def test_least_squares_recovers_masses_springs_and_dampers(frame, model):
    score = identify(frame, "least-squares", "--model", str(SHEAR_FRAME), "--test", "forced",
                     "--samples", "8", "--interval", "0.1")
    (result,) = score["runs"]
    assert result["labels"] == [p.label for p in model.parameters]
    assert {label.split("[")[0] for label in result["labels"]} == {"mass", "stiffness", "damping"}
    assert np.max(np.abs(result["errors"])) < 1e-6


def test_rayleigh_finds_the_natural_frequencies(frame, model):
    score = identify(frame, "rayleigh", "--model", str(SHEAR_FRAME), "--test", "free")
    (result,) = score["runs"]
    assert len(result["omega"]) == 3
    assert np.abs(result["freq_error_pct"]).max() < 0.5
    assert result["omega_true"] == pytest.approx(model.modes().omega, rel=1e-12)
