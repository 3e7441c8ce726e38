"""Frequency-domain least squares (identifier/least_squares/frequency.py,
frequency_output.py, frequency_data.py): the equations of motion on FRFs,
``(K - omega^2 M + i omega C) H = e_f``, against closed-form FRFs of a 2-DOF
chain and against the time-domain estimator on FMU-generated traces."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import foreign_fixtures as msd
from structbench.harness.run import run_campaign
from structbench.identifier.io.traces import read_trace
from structbench.identifier.least_squares import identify
from structbench.identifier.least_squares.frequency import Lines, solve_lines
from structbench.identifier.least_squares.frequency_output import refine
from structbench.models import load_model
from structbench.models.toml_model import structure_from_dict

OMEGA = np.linspace(20.0, 250.0, 60)  # rad/s: both modes (63, 159 rad/s) inside


def _chain_dict() -> dict:
    """The model file of :func:`chain`."""
    return {
        "name": "chain2", "unknown": ["mass", "damping", "stiffness"],
        "nodes": [{"id": 0, "x": 0.0}, {"id": 1, "x": 1.0}, {"id": 2, "x": 2.0}],
        "supports": [{"node": 0, "fix": ["x"]}],
        "elements": [{"type": "mass", "nodes": [1], "dir": "x", "m": 1.0},
                     {"type": "mass", "nodes": [2], "dir": "x", "m": 0.5},
                     {"type": "spring", "nodes": [0, 1], "dir": "x", "k": 1.0e4},
                     {"type": "spring", "nodes": [1, 2], "dir": "x", "k": 5.0e3},
                     {"type": "dashpot", "nodes": [0, 1], "dir": "x", "c": 10.0},
                     {"type": "dashpot", "nodes": [1, 2], "dir": "x", "c": 4.0}]}


def chain():
    """Two masses in a chain from a wall: m 1, 0.5 kg; k 1e4, 5e3 N/m; c 10, 4 N s/m (all unknown)."""
    return structure_from_dict(_chain_dict())


def closed_form(model, omega: np.ndarray) -> np.ndarray:
    """``H = (K - omega^2 M + i omega C)^-1`` (L, n, n), m/N."""
    M, C, K = (a.toarray() for a in (model.mass(), model.damping(), model.stiffness()))
    return np.linalg.inv(K[None] - omega[:, None, None] ** 2 * M + 1j * omega[:, None, None] * C)


def lines(model, rng=None, noise: float = 0.0) -> Lines:
    """Receptance lines for a force at each DOF in turn; complex Gaussian noise
    of standard deviation ``noise`` x the column's mean |H| on every entry."""
    H = closed_form(model, OMEGA)
    parts = []
    for f in range(model.n_dof):
        h = H[:, :, f]
        var = np.broadcast_to((noise * np.abs(h).mean(axis=0)) ** 2, h.shape).copy()
        if noise:
            h = h + np.sqrt(var / 2) * (rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape))
        parts.append(Lines(OMEGA.copy(), h, var, np.full(OMEGA.size, f), np.arange(OMEGA.size)))
    return Lines.join(parts)


def test_noise_free_frfs_give_the_parameters():
    model = chain()
    truth = model.values
    linear = solve_lines(model, lines(model))
    assert np.max(np.abs(linear.values / truth - 1)) < 1e-8
    p, std, _ = refine(model, lines(model), truth * 1.2)
    assert np.max(np.abs(p / truth - 1)) < 1e-8


def test_bias_compensation_removes_the_errors_in_variables_bias():
    """5 % noise on every FRF entry, 50 realisations: the bias-compensated
    and the output-error estimates are unbiased (means within 3.5 standard
    errors of the mean), plain least squares on the same equations is not."""
    model = chain()
    truth = model.values
    rng = np.random.default_rng(22)
    runs = {"compensated": [], "plain": [], "output": []}
    for _ in range(50):
        data = lines(model, rng, 0.05)
        compensated = solve_lines(model, data)
        runs["compensated"].append(compensated.values / truth - 1)
        runs["plain"].append(solve_lines(model, data, compensate=False).values / truth - 1)
        runs["output"].append(refine(model, data, compensated.values)[0] / truth - 1)
    t = {k: np.mean(v, axis=0) / (np.std(v, axis=0, ddof=1) / np.sqrt(len(v))) for k, v in runs.items()}
    assert np.max(np.abs(t["compensated"])) < 3.5, t["compensated"]
    assert np.max(np.abs(t["output"])) < 3.5, t["output"]
    assert np.max(np.abs(t["plain"])) > 6.0, t["plain"]
    assert np.all(np.mean(runs["plain"], axis=0)[:4] < 0)  # masses and stiffnesses shrink


def test_coverage_of_the_95_percent_intervals():
    """200 realisations x 6 parameters: the output-error estimate's 95 %
    intervals cover in a binomial band (the intervals of one realisation
    are correlated: a wide band, 0.92-0.98)."""
    model = chain()
    truth = model.values
    rng = np.random.default_rng(2022)
    inside = []
    for _ in range(200):
        data = lines(model, rng, 0.05)
        p, std, _ = refine(model, data, solve_lines(model, data, errors=False).values)
        inside.append(np.abs(p - truth) < 1.96 * std)
    assert 0.92 <= np.mean(inside) <= 0.98, np.mean(inside, axis=0)


def test_output_error_jacobian_matches_finite_differences():
    """The Jacobian of the whitened model FRF (frequency_jacobian.evaluate:
    each parameter's few rows, dense product or gather) against central
    differences of ``Z(p)^-1 e_f / sd``, on the 2-DOF chain with Rayleigh
    damping (every parameter also in C) and on the chapter 3 damped beam;
    ``Re(J^H J)`` and ``Re(J^H r)`` against the complex products."""
    from structbench.identifier.least_squares.frequency import Equations
    from structbench.identifier.least_squares.frequency_jacobian import Derivatives, evaluate

    rng = np.random.default_rng(7)
    for model in (_rayleigh_chain(), load_model("ch3-damped-beam")):
        eq, u = Equations(model), np.flatnonzero(model.kind_mask())
        n, B = model.n_dof, 40
        data = Lines(rng.uniform(5.0, 200.0, B), rng.standard_normal((B, n)) + 1j * rng.standard_normal((B, n)),
                     rng.uniform(0.5, 2.0, (B, n)), rng.integers(0, n, B), np.arange(B) // 8)
        p = model.values * rng.uniform(0.9, 1.1, model.values.size)
        for dense in (True, False):
            deriv = Derivatives(eq, u)
            deriv.dense = dense
            ev = evaluate(eq, deriv, data, p)
            for k, j in enumerate(u):
                step = 1e-6 * abs(p[j])
                hi, lo = p.copy(), p.copy()
                hi[j] += step
                lo[j] -= step
                fd = (evaluate(eq, deriv, data, hi).hh - evaluate(eq, deriv, data, lo).hh) / (2 * step) / ev.sd
                assert np.max(np.abs(ev.J[:, k] - fd)) < 1e-6 * np.max(np.abs(fd)), (model.name, k, dense)
            r = ev.residual(data)
            Jf = ev.J.transpose(0, 2, 1).reshape(-1, u.size)
            A, g = ev.normal(r)
            assert np.max(np.abs(A - (Jf.conj().T @ Jf).real)) < 1e-12 * np.max(np.abs(A))
            assert np.max(np.abs(g - (Jf.conj().T @ r.ravel()).real)) < 1e-12 * np.max(np.abs(g))


def _rayleigh_chain():
    """:func:`chain` with Rayleigh damping ``C = c + 0.5 M + 2e-4 K``."""
    return structure_from_dict(_chain_dict() | {"name": "chain2-rayleigh", "rayleigh": [0.5, 2e-4]})


def test_frequency_domain_refuses_a_single_line():
    """A single line excites too little: rank deficiency, naming parameters."""
    from structbench.identifier.errors import IdentificationError

    model = chain()
    one = lines(model).take(np.array([5]))
    one = Lines(one.omega, one.h, one.var, one.force, one.cluster)
    with pytest.raises(IdentificationError, match="not identifiable|fewer equations"):
        solve_lines(model, one)


def test_fmu_traces_frequency_against_time_domain(tmp_path):
    """Traces of the foreign FMU (tests/foreign_fmu: gcc-built, model
    exchange; position with a 1 mm offset), two 10 s records of a random
    force, 2 % noise: the frequency domain (Welch H1 pooled over the records) and the time domain (prefiltered, offsets estimated) agree
    with each other (4 combined standard errors) and with the FMU's m and k
    within 1 %, c within 10 % (leakage), each within 4 standard errors."""
    campaign = msd.msd_campaign(tmp_path, msd.build_msd(tmp_path), 11, """\
[[tests]]
name = "random"
dt = 0.001
duration = 10.0
repetitions = 2
noise = {sensor = {displacement = 0.02, force = 0.02}}
excitation = [{kind = "random", node = 1, dir = "x", rms = 10.0, band = [5.0, 1000.0], realisation = "per-repetition"}]
sensors = [{nodes = [1], dirs = ["x"], quantities = ["displacement", "force"]}]
""")
    out = tmp_path / "out"
    status = run_campaign(campaign, out, jobs=0, check_step="off")
    assert not status.failed
    traces = [read_trace(p) for p in sorted((out / "traces").glob("*.h5"))]
    model = load_model(Path(__file__).resolve().parent / "foreign_fmu" / "msd.toml")
    truth = {"mass[1]": msd.M, "damping[3]": msd.D, "stiffness[2]": msd.K}
    freq = identify(traces, model, domain="frequency")
    time = identify(traces, model, domain="time")
    assert freq.details["domain"]["chosen"] == "frequency" and time.details["domain"]["chosen"] == "time"
    for pf, pt in zip(freq.parameters, time.parameters):
        # Welch leakage (1 s segments, zeta 5 %) widens the peak: the damping comes out a few % high
        assert abs(pf.value / truth[pf.label] - 1) < (0.1 if pf.kind == "damping" else 0.01), pf
        assert abs(pf.value - truth[pf.label]) < 4 * pf.std_error, pf
        assert abs(pf.value - pt.value) < 4 * np.hypot(pf.std_error, pt.std_error), (pf, pt)


@pytest.mark.parametrize("dt, domain", [(0.01, "frequency"), (0.001, "time")])
def test_auto_domain_by_band_and_nyquist(dt, domain):
    """Displacements only (2 % noise) of the 2-DOF chain under a white force
    held over each sample: at dt = 10 ms its band (about 100 rad/s) is near
    Nyquist (314 rad/s) and ``auto`` takes the frequency domain, at 1 ms the
    prefiltered time domain; either way m, k within 2 % and every parameter
    within 4 standard errors."""
    from dataclasses import replace

    from identify_synth import memory_trace, respond

    model = chain()
    n = int(round(100.0 / dt))
    force = np.zeros((n, 2))
    force[:, 1] = 10.0 * np.random.default_rng(7).standard_normal(n)
    response = respond(model, force, dt)
    sensors = [("displacement", 1, "x"), ("displacement", 2, "x"), ("force", 2, "x")]
    trace = replace(memory_trace(model, response, dt, sensors, {"displacement": 0.02, "force": 0.02}, seed=8),
                    excitation_attrs={"kind": "random"})
    result = identify([trace], model)
    assert result.details["domain"]["chosen"] == domain, result.details["domain"]
    truth = dict(zip([p.label for p in model.parameters], model.values))
    for p in result.parameters:
        assert abs(p.value - truth[p.label]) < 4 * p.std_error, p
        if p.kind != "damping":
            assert abs(p.value / truth[p.label] - 1) < 0.02, p
