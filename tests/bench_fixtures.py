"""Helpers for the bench tests: a foreign-named test FMU, small campaigns,
reading and comparing trace folders."""
from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

TWO_MASS_SLAVE = '''
"""Ground -k1- m1 -k2- m2 along z, with its own variable names. Outputs NaN
for forces above 1 kN, fails (raises) above 1 MN, kills its process at 777 N."""
import math
import os

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real


class TwoMass(Fmi2Slave):
    author = "structbench tests"
    description = "two masses on springs"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.par = {"Structure.m1": 1.0, "Structure.m2": 2.0, "Structure.k1": 100.0, "Structure.k2": 50.0}
        self.u, self.v, self.f = [0.0, 0.0], [0.0, 0.0], [0.0, 0.0]
        for name in self.par:
            self.register_variable(Real(name, causality=Fmi2Causality.parameter,
                                        variability=Fmi2Variability.tunable,
                                        getter=lambda n=name: self.par[n],
                                        setter=lambda x, n=name: self.par.__setitem__(n, x)))
        for i in range(2):
            node = f"Structure.Node{i + 1}"
            self.register_variable(Real(f"{node}.Fz", causality=Fmi2Causality.input,
                                        getter=lambda i=i: self.f[i],
                                        setter=lambda x, i=i: self.f.__setitem__(i, x)))
            self.register_variable(Real(f"{node}.Uz", causality=Fmi2Causality.output, getter=lambda i=i: self.u[i]))
            self.register_variable(Real(f"{node}.Vz", causality=Fmi2Causality.output, getter=lambda i=i: self.v[i]))
            self.register_variable(Real(f"{node}.Az", causality=Fmi2Causality.output,
                                        getter=lambda i=i: self.acc()[i]))

    def acc(self):
        p, (u1, u2), (f1, f2) = self.par, self.u, self.f
        if max(abs(f1), abs(f2)) > 1e3:
            return [math.nan, math.nan]
        s1 = p["Structure.k1"] * u1 - p["Structure.k2"] * (u2 - u1)
        s2 = p["Structure.k2"] * (u2 - u1)
        return [(f1 - s1) / p["Structure.m1"], (f2 - s2) / p["Structure.m2"]]

    def do_step(self, current_time, step_size):
        if max(abs(f) for f in self.f) > 1e6:
            raise RuntimeError("actuator overload")
        if 777.0 in self.f:
            os._exit(3)
        n = 50
        h = step_size / n
        for _ in range(n):
            a = self.acc()
            self.v = [self.v[i] + h * a[i] for i in range(2)]
            self.u = [self.u[i] + h * self.v[i] for i in range(2)]
        return True
'''


def build_two_mass(folder: Path) -> Path:
    """Build ``folder/TwoMass.fmu`` with pythonfmu."""
    from pythonfmu.builder import FmuBuilder

    script = folder / "two_mass_test_slave.py"
    script.write_text(TWO_MASS_SLAVE)
    return Path(FmuBuilder.build_FMU(script, dest=folder))


def read_h5(path: Path) -> dict:
    """Every attribute and dataset of an HDF5 file: ``{"/path": (attrs, data)}``."""
    out = {}

    def visit(name: str, obj) -> None:
        data = obj[()] if isinstance(obj, h5py.Dataset) else None
        out["/" + name] = (dict(obj.attrs), data)

    with h5py.File(path, "r") as f:
        out["/"] = (dict(f.attrs), None)
        f.visititems(visit)
    return out


def same(a, b) -> bool:
    """Equal values, bit for bit for arrays (NaN equal to NaN)."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
    return type(a) is type(b) and a == b


def assert_same_h5(a: Path, b: Path) -> None:
    """Two trace files hold the same datasets and attributes."""
    da, db = read_h5(a), read_h5(b)
    assert da.keys() == db.keys(), (a.name, sorted(set(da) ^ set(db)))
    for key in da:
        (attrs_a, data_a), (attrs_b, data_b) = da[key], db[key]
        assert attrs_a.keys() == attrs_b.keys(), (a.name, key)
        for name in attrs_a:
            assert same(attrs_a[name], attrs_b[name]), (a.name, key, name)
        assert (data_a is None and data_b is None) or same(data_a, data_b), (a.name, key)


def assert_same_traces(a: Path, b: Path) -> None:
    """Two campaign folders hold the same trace files, file by file."""
    names_a = sorted(p.name for p in (a / "traces").glob("*.h5"))
    names_b = sorted(p.name for p in (b / "traces").glob("*.h5"))
    assert names_a == names_b
    assert names_a
    for name in names_a:
        assert_same_h5(a / "traces" / name, b / "traces" / name)
