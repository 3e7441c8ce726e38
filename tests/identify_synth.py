"""Synthetic trace files for the identifier tests, written in the documented
format (docs/trace-format.md) from the models' exact simulation
(``StateSpace.simulate``: force[k] held over [t_k, t_k + dt), responses at t_k)."""
from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING

import h5py
import numpy as np

if TYPE_CHECKING:
    from structbench.identifier.io.traces import Trace

UNITS = {"displacement": ("m", "rad"), "velocity": ("m/s", "rad/s"),
         "acceleration": ("m/s^2", "rad/s^2"), "force": ("N", "N m")}


def respond(model, force: np.ndarray, dt: float, x0: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Exact sampled response (n, n_dof) per quantity, plus the ``force`` itself."""
    out = model.state_space().simulate(force, dt, x0)
    return {"displacement": out["displacement"], "velocity": out["velocity"],
            "acceleration": out["acceleration"], "force": np.asarray(force, dtype=float)}


def harmonic_force(model, node: int, direction: str, amplitude: float, omega: float, time: np.ndarray,
                   ramp: float = 0.0) -> np.ndarray:
    """``amplitude cos(omega t)`` at one DOF after a ``ramp`` s raised-cosine soft start, (n, n_dof)."""
    env = np.where(time < ramp, 0.5 * (1 - np.cos(np.pi * time / ramp)), 1.0) if ramp > 0 else 1.0
    f = np.zeros((time.size, model.n_dof))
    f[:, model.dof_index(node, direction)] = amplitude * env * np.cos(omega * time)
    return f


def _location(model, node: int) -> list[float]:
    xyz = np.zeros(3)
    coords = np.asarray(model.nodes[node], dtype=float)
    xyz[:coords.size] = coords
    return xyz.tolist()


def _dataset(group, name, data, quantity, node, direction, location, ratio, mode):
    ds = group.create_dataset(name, data=np.asarray(data, dtype=float))
    ds.attrs.update({"quantity": quantity, "unit": UNITS[quantity][direction == "theta"], "node": node,
                     "direction": direction, "location": location, "noise_ratio": ratio, "noise_mode": mode})


def write_trace(path: str | Path, model, response: dict[str, np.ndarray], dt: float,
                sensors: list[tuple[str, int, str]], noise: dict[str, float] | None = None,
                seed: int = 0, mode: str = "rms", test: str = "test", repetition: int = 0,
                excitation_attrs: dict | None = None, commanded: np.ndarray | None = None,
                drop: tuple[str, ...] = ()) -> Path:
    """One trace file: ``sensors`` as (quantity, node, direction) with sensor
    noise ``noise[quantity]`` (ratio at one sigma, numpy Generator ``seed``);
    ``commanded`` (n, n_dof) becomes ``/excitation`` (default: the response's
    force); channel names in ``drop`` are left out."""
    noise = noise or {}
    rng = np.random.default_rng(seed)
    n = response["force"].shape[0]
    commanded = response["force"] if commanded is None else commanded
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with h5py.File(path, "w") as f:
        f.attrs.update({"format": "structbench-trace", "format_version": 1, "campaign": "synthetic",
                        "test": test, "repetition": repetition, "structure": model.name, "fmu_name": "",
                        "fmu_sha256": "", "software": "tests", "seed": seed, "dt": dt})
        f.create_dataset("time", data=np.arange(n) * dt).attrs["unit"] = "s"
        channels = f.create_group("channels")
        for quantity, node, direction in sensors:
            name = f"{quantity}_{node}_{direction}"
            if name in drop:
                continue
            clean = response[quantity][:, model.dof_index(node, direction)]
            ratio = noise.get(quantity, 0.0)
            scale = np.abs(clean) if mode == "proportional" else np.sqrt(np.mean(clean**2))
            data = clean + ratio * scale * rng.standard_normal(n)
            _dataset(channels, name, data, quantity, node, direction, _location(model, node), ratio, mode)
        excitation = f.create_group("excitation")
        for j in np.flatnonzero(np.any(commanded != 0, axis=0)):
            node, direction = model.dofs[j]
            _dataset(excitation, f"force_{node}_{direction}", commanded[:, j], "force", node, direction,
                     _location(model, node), 0.0, mode)
        attrs = {"kind": "harmonic", "spec": "[]"} | (excitation_attrs or {})
        excitation.attrs.update({k: json.dumps(v) if isinstance(v, (list, dict)) else v for k, v in attrs.items()})
        f.create_group("noise").attrs.update({"sensor_ratio": max(noise.values(), default=0.0),
                                             "sensor_mode": mode, "seed": seed})
    return path


def cantilever_trace(path: str | Path, noise: dict[str, float] | None = None) -> Path:
    """A short trace of the chapter 4 case 1 cantilever under 1 N at 0.5 rad/s at
    node 7 (10 s at 0.05 s): tip and root displacements and the tip force."""
    from structbench.models import load_model

    model = load_model("ch4-cantilever-case1")
    t = np.arange(201) * 0.05
    response = respond(model, harmonic_force(model, 7, "w", 1.0, 0.5, t), 0.05)
    return write_trace(path, model, response, 0.05,
                       [("displacement", 7, "w"), ("displacement", 2, "theta"), ("force", 7, "w")],
                       noise=noise, test="a", excitation_attrs={"omega": 0.5})


def memory_trace(model, response: dict[str, np.ndarray], dt: float, sensors: list[tuple[str, int, str]],
                 noise: dict[str, float] | None = None, seed: int = 0, name: str = "r.h5",
                 repetition: int = 0) -> "Trace":
    """Like :func:`write_trace` (rms-mode noise ``noise[quantity]`` from numpy
    Generator ``seed``, declared on each channel) but an in-memory
    :class:`Trace`, no file."""
    from structbench.identifier.io.traces import Channel, Trace

    noise = noise or {}
    rng = np.random.default_rng(seed)
    n = response["force"].shape[0]
    channels = {}
    for quantity, node, direction in sensors:
        clean = response[quantity][:, model.dof_index(node, direction)]
        ratio = noise.get(quantity, 0.0)
        data = clean + ratio * np.sqrt(np.mean(clean**2)) * rng.standard_normal(n)
        cname = f"{quantity}_{node}_{direction}"
        channels[cname] = Channel(cname, data, quantity, UNITS[quantity][direction == "theta"], node, direction,
                                  np.array(_location(model, node)), ratio, "rms")
    return Trace(path=Path(name), time=np.arange(n) * dt, dt=dt, step=dt, channels=channels, excitation={},
                 attrs={"test": "test", "repetition": repetition, "structure": model.name})


def oscillator(m: float = 1.0, c: float = 10.0, k: float = 1.0e4):
    """A 1-DOF oscillator (node 1, direction x; node 0 fixed): mass ``m`` kg,
    dashpot ``c`` N s/m, spring ``k`` N/m, all three unknown."""
    from structbench.models.toml_model import structure_from_dict

    return structure_from_dict({
        "name": "oscillator", "unknown": ["mass", "damping", "stiffness"],
        "nodes": [{"id": 0, "x": 0.0}, {"id": 1, "x": 1.0}], "supports": [{"node": 0, "fix": ["x"]}],
        "elements": [{"type": "mass", "nodes": [1], "dir": "x", "m": m},
                     {"type": "spring", "nodes": [0, 1], "dir": "x", "k": k},
                     {"type": "dashpot", "nodes": [0, 1], "dir": "x", "c": c}]})
