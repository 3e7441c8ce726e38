"""Least squares with unmeasured DOF (identifier/least_squares/unmeasured.py,
unmeasured_data.py): the output error at the measured DOF, unmeasured DOF
condensed, started from the topology alone; against closed-form FRFs of
small chains, a Monte Carlo of its intervals, refusals, and simulated traces."""
from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest
import scipy.linalg as la

from identify_synth import memory_trace, respond
from structbench.dispatch.runs import topology
from structbench.identifier.errors import IdentificationError
from structbench.identifier.least_squares import identify
from structbench.identifier.least_squares.frequency import Lines
from structbench.identifier.least_squares.unmeasured import solve
from structbench.models.toml_model import structure_from_dict

OMEGA = np.linspace(20.0, 250.0, 60)  # rad/s


def chain(n: int = 2, unknown: tuple[str, ...] = ("mass", "damping", "stiffness")):
    """``n`` masses in a chain from a wall (masses 1, 0.5, 0.8 kg; springs
    1e4, 5e3, 8e3 N/m; dashpots 10, 4, 6 N s/m)."""
    m, k, c = [1.0, 0.5, 0.8][:n], [1.0e4, 5.0e3, 8.0e3][:n], [10.0, 4.0, 6.0][:n]
    return structure_from_dict({
        "name": f"chain{n}", "unknown": list(unknown),
        "nodes": [{"id": j, "x": float(j)} for j in range(n + 1)], "supports": [{"node": 0, "fix": ["x"]}],
        "elements": [{"type": "mass", "nodes": [j + 1], "dir": "x", "m": m[j]} for j in range(n)]
        + [{"type": "spring", "nodes": [j, j + 1], "dir": "x", "k": k[j]} for j in range(n)]
        + [{"type": "dashpot", "nodes": [j, j + 1], "dir": "x", "c": c[j]} for j in range(n)]})


def lines(model, force: int, seen: list[int], rng=None, noise: float = 0.0) -> Lines:
    """Closed-form receptance ``(K - omega^2 M + i omega C)^-1 e_force`` at
    the DOF ``seen`` (the others unmeasured: var inf); complex Gaussian noise
    of standard deviation ``noise`` x the entry's mean |H| over the lines."""
    M, C, K = (a.toarray() for a in (model.mass(), model.damping(), model.stiffness()))
    Z = K[None] - OMEGA[:, None, None] ** 2 * M + 1j * OMEGA[:, None, None] * C
    h = np.linalg.inv(Z)[:, :, force]
    var = np.broadcast_to((max(noise, 1e-6) * np.abs(h).mean(axis=0)) ** 2, h.shape).copy()
    if noise:
        h = h + np.sqrt(var / 2) * (rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape))
    hidden = np.setdiff1d(np.arange(model.n_dof), seen)
    h[:, hidden], var[:, hidden] = 0.0, np.inf
    return Lines(OMEGA.copy(), h, var, np.full(OMEGA.size, force), np.arange(OMEGA.size))


@pytest.mark.parametrize("n, force, seen", [(2, 0, [0]), (3, 2, [0, 2]), (3, 0, [0])])
def test_noise_free_frfs_give_the_parameters_from_the_topology(n, force, seen):
    """Exact FRFs at some DOF only, the model's values all 1.0: every
    parameter to 1e-7 (the start knows nothing but the topology)."""
    model = chain(n)
    p, std, bad, info = solve(topology(model), lines(model, force, seen))
    assert not bad.any() and info["undetermined"] == []
    assert np.max(np.abs(p / model.values - 1)) < 1e-7, p / model.values - 1


def test_coverage_of_the_95_percent_intervals():
    """2-DOF chain, force and sensor at the driving point only (DOF 2 never
    measured), 5 % noise, 100 realisations x 6 parameters, the fit from the
    truth: unbiased (means within 3.5 standard errors of the mean) and the
    95 % intervals cover in a binomial band (intervals of one realisation
    are correlated: 0.91-0.985). The first 10 from the topology alone reach
    the same estimates."""
    model = chain(2)
    truth = model.values
    rng = np.random.default_rng(2201)
    err, inside = [], []
    for i in range(100):
        data = lines(model, 0, [0], rng, 0.05)
        p, std, bad, _ = solve(model, data, truth)
        if i < 10:
            assert np.max(np.abs(solve(topology(model), data)[0] / p - 1)) < 1e-4
        assert not bad.any()
        err.append(p / truth - 1)
        inside.append(np.abs(p - truth) < 1.96 * std)
    t = np.mean(err, axis=0) / (np.std(err, axis=0, ddof=1) / np.sqrt(len(err)))
    assert np.max(np.abs(t)) < 3.5, t
    assert 0.91 <= np.mean(inside) <= 0.985, np.mean(inside, axis=0)


def parallel(unknown: list[str]):
    """Masses 1 and 0.5 kg (nodes 1, 2); the wall to node 1 through two
    parallel springs (k_a 6e3, k_b 4e3 N/m: only their sum acts) and a
    dashpot 10 N s/m; node 1 to node 2 through a spring 5e3 N/m (when
    ``with_link``) and a dashpot 4 N s/m."""
    link = [{"type": "spring", "nodes": [1, 2], "dir": "x", "k": 5.0e3}] if "mass" in unknown else []
    return structure_from_dict({
        "name": "parallel", "unknown": unknown,
        "nodes": [{"id": 0, "x": 0.0}, {"id": 1, "x": 1.0}, {"id": 2, "x": 2.0}],
        "supports": [{"node": 0, "fix": ["x"]}],
        "elements": [{"type": "mass", "nodes": [1], "dir": "x", "m": 1.0},
                     {"type": "mass", "nodes": [2], "dir": "x", "m": 0.5},
                     {"type": "spring", "nodes": [0, 1], "dir": "x", "k": 6.0e3},
                     {"type": "spring", "nodes": [0, 1], "dir": "x", "k": 4.0e3},
                     {"type": "dashpot", "nodes": [0, 1], "dir": "x", "c": 10.0},
                     {"type": "dashpot", "nodes": [1, 2], "dir": "x", "c": 4.0}] + link})


def test_undetermined_parameters_are_reported_not_numbers():
    """DOF 2 unmeasured, two parallel springs: their sum is determined, each
    one is not (null space of the Gauss-Newton matrix); the rest exact."""
    model = parallel(["mass", "damping", "stiffness"])
    p, std, bad, info = solve(topology(model), lines(model, 0, [0]))
    labels = [q.label for q in model.parameters if q.kind in model.unknown]
    assert info["undetermined"] == ["stiffness[3]", "stiffness[4]"], info["undetermined"]
    assert bad.tolist() == [lab in ("stiffness[3]", "stiffness[4]") for lab in labels]
    assert np.all(np.isnan(std[bad])) and np.all(np.isfinite(std[~bad]))
    assert np.max(np.abs(p[model.kind_mask()][~bad] / model.values[model.kind_mask()][~bad] - 1)) < 1e-6
    assert abs((p[2] + p[3]) / 1.0e4 - 1) < 1e-6  # the sum is determined


def test_nothing_determined_is_refused_naming_what_is_missing():
    model = parallel(["stiffness"])
    with pytest.raises(IdentificationError, match=r"no parameter is determined .*stiffness\[3\], stiffness\[4\] "
                                                  r"undetermined; unmeasured DOF \(2, 'x'\)"):
        solve(model, lines(model, 0, [0]))


def test_traces_with_an_unmeasured_dof_take_this_path():
    """A 3-DOF chain under a random force at DOF 3 (held over each 2 ms
    sample, 16384 samples), velocities at DOF 1 and 3 only, 2 % noise:
    ``identify`` (default options, the topology) chooses the frequency
    domain naming the unmeasured DOF; every parameter within 4 standard
    errors and 5 % (damping 15 %: leakage) of the truth."""
    model = chain(3)
    dt, n = 0.002, 16384
    rng = np.random.default_rng(7)
    force = np.zeros((n, 3))
    force[:, 2] = rng.standard_normal(n)
    sensors = [("velocity", 1, "x"), ("velocity", 3, "x"), ("force", 3, "x")]
    trace = memory_trace(model, respond(model, force, dt), dt, sensors, {"velocity": 0.02, "force": 0.02}, seed=8)
    trace = dataclasses.replace(trace, excitation_attrs={"kind": "random"})
    result = identify([trace], topology(model))
    assert result.details["domain"]["chosen"] == "frequency" and "unmeasured DOF" in result.details["domain"]["why"]
    assert result.details["unmeasured_dofs"] == [[2, "x"]]
    values = result.values()
    std = np.array([q.std_error for q in result.parameters])
    tol = np.array([0.15 if q.kind == "damping" else 0.05 for q in result.parameters])
    assert np.all(np.abs(values - model.values) < 4 * std), (values / model.values - 1, std / model.values)
    assert np.all(np.abs(values / model.values - 1) < tol), values / model.values - 1
    with pytest.raises(IdentificationError, match=r"time domain needs .* DOF \(2, 'x'\) has none"):
        identify([trace], topology(model), domain="time")


def test_too_few_clusters_of_lines_are_refused_not_answered():
    """3-DOF chain, DOF 2 unmeasured, 9 unknowns, the 12 lowest lines with
    2 % noise: as 6 clusters of 2 correlated lines (fewer than the 9
    determined parameters: no standard error can be checked against the
    data) refused naming the counts and what would do; the same lines as 12
    independent clusters are answered, within 5 standard errors."""
    model = chain(3)
    data = lines(model, 0, [0, 2], np.random.default_rng(2202), 0.02).take(np.arange(OMEGA.size) < 12)
    few = dataclasses.replace(data, cluster=data.cluster // 2)
    with pytest.raises(IdentificationError, match=r"cannot support an estimate: 12 coherent lines in 6 clusters .* "
                                                  r"9 determined parameters.* unmeasured DOF \(2, 'x'\): measure "
                                                  r"velocities or accelerations"):
        solve(topology(model), few)
    with warnings.catch_warnings():  # its errors solved in the scaled form: no ill-conditioned solve
        warnings.simplefilter("error", la.LinAlgWarning)
        p, std, bad, info = solve(topology(model), data)
    assert not bad.any() and info["clusters"] == 12 and info["lines"] == 12
    assert np.all(np.abs(p - model.values) < 5 * std), (p / model.values - 1, std / model.values)


def test_sampling_refusal_suggests_sensors_by_the_quantities_measured() -> None:
    """Displacements alone: velocities or accelerations would do; with them already measured, more DOF."""
    from types import SimpleNamespace

    from structbench.identifier.least_squares.unmeasured_data import _remedy
    assert "velocities or accelerations" in _remedy([SimpleNamespace(levels=np.array([0, 0]))])
    assert "velocities" not in _remedy([SimpleNamespace(levels=np.array([0, 2]))])
