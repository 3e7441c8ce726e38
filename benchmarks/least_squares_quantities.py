"""Least squares from one response quantity per DOF (issue 22): the
prefiltered equations of motion (identifier/least_squares/prefilter.py) on
exact zero-order-hold simulations in numpy, in-memory traces (no FMU).

Cases, each with 2 % rms-mode noise on every channel (force included):

- the chapter 3 beam's harmonic test (``ch3-free-free-beam``, 0.1 cos t N
  at node 7 from rest, 4 s at 1 ms) measured by displacement sensors only,
  and by velocity sensors only: median normalized RMS parameter error
  (10-90 %) and the coverage of the stated 95 % intervals, over noise seeds
  ``0 .. seeds-1`` (numpy Generator seed per trace);
- a 1-DOF oscillator (1 kg, 1e4 N/m, 10 N s/m) measured by position and
  force, one run = 5 repetitions (traces) of a 4 s impulse (100 N over the
  first 1 ms step) or of a 120 s random test (Gaussian force, 10 N per held
  step, a new realisation per repetition): per parameter the median and
  largest |relative error| and the coverage of the 95 % intervals over runs
  ``0 .. runs-1``; repetition ``r`` of run ``i`` has noise seed ``10 i + r``,
  random force seed ``2_000_000 + 10 i + r``; ``--offset`` (m) adds a
  constant to the position before the noise (a probe's zero, as the
  foreign FMU of benchmarks/foreign_fmu.py has: the noise is then 2 % of the
  RMS with the offset), which least squares estimates
  (identifier/least_squares/offsets.py).

The constants of the method (filter order, corner ``2 x band``, the force's
smoothing passes) were chosen on other seeds: ch3 noise seeds 5000-5009,
oscillator noise seeds 10000-10399 and forces 1_010_000-1_010_199; the
tests use 900_000 onwards.

    python benchmarks/least_squares_quantities.py [--seeds 20] [--runs 200] [--offset 0.001]
        [--cases beam-displacement beam-velocity impulse random]

Measured (commit 202d97e: offsets estimated when the chi-square test finds
them; --runs 100):

    ch3 displacement only (20 seeds): normalized RMS median 0.00218 (p10 0.00159, p90 0.00295),
        coverage 0.942; velocity only: 0.00134 (0.00098, 0.00157), coverage 0.968 (as before
        the offsets: no offset found)
    1-DOF impulse: median |error| m 0.043 %, k 0.043 %, c 0.140 % (largest 0.21, 0.21,
        0.61 %), coverage 0.97, 0.95, 0.94 (no offset found)
    1-DOF impulse, --offset 0.001 (the noise, 2 % of the RMS with the offset, 9 times
        larger): m 0.215 %, k 0.181 %, c 0.329 % (largest 1.08, 1.10, 0.96 %), coverage
        0.95, 0.97, 0.86 (the damping's interval leaves out the error of the fixed
        phi_1 term, about C u0 / impulse = 10 % of the damping's: offsets.py)
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import scipy.linalg as la
from scipy.signal import lfilter, ss2tf

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from identify_synth import memory_trace, oscillator, respond  # noqa: E402
from structbench.identifier.least_squares import identify  # noqa: E402
from structbench.models import load_model  # noqa: E402

DT = 0.001
NOISE = {"displacement": 0.02, "velocity": 0.02, "acceleration": 0.02, "force": 0.02}


def beam_case(quantity: str, seeds: int) -> None:
    beam = load_model("ch3-free-free-beam")
    t = np.arange(4001) * DT
    force = np.zeros((t.size, beam.n_dof))
    force[:, beam.dof_index(7, "w")] = 0.1 * np.cos(t)
    response = respond(beam, force, DT)
    sensors = [(quantity, n, d) for n, d in beam.dofs] + [("force", 7, "w")]
    truth = beam.values[beam.kind_mask()]
    rms, z = [], []
    for seed in range(seeds):
        result = identify([memory_trace(beam, response, DT, sensors, NOISE, seed=seed)], beam)
        rms.append(np.sqrt(np.mean((result.values() / truth - 1) ** 2)))
        z.append((result.values() - truth) / np.array([p.std_error for p in result.parameters]))
    p10, med, p90 = np.percentile(rms, [10, 50, 90])
    print(f"ch3 harmonic, {quantity} only: normalized RMS median {med:.5f} (p10 {p10:.5f}, p90 {p90:.5f}) "
          f"over {seeds} seeds; 95 % coverage {np.mean(np.abs(z) < 1.96):.3f}; "
          f"lambda {result.details['prefilter']['lambda']:.3g} rad/s")


def oscillator_displacement(model, force: np.ndarray) -> np.ndarray:
    """Exact ZOH displacement (n,) of the 1-DOF model: force[k] held over step k."""
    m, c, k = (float(model.mass().toarray()[0, 0]), float(model.damping().toarray()[0, 0]),
               float(model.stiffness().toarray()[0, 0]))
    A = np.array([[0.0, 1.0], [-k / m, -c / m]])
    big = la.expm(np.block([[A, np.array([[0.0], [1.0 / m]])], [np.zeros((1, 3))]]) * DT)
    b, a = ss2tf(big[:2, :2], big[:2, 2:], np.array([[1.0, 0.0]]), np.zeros((1, 1)))
    return lfilter(b[0], a, force)


def oscillator_case(kind: str, runs: int, offset: float = 0.0) -> None:
    model = oscillator()
    truth = model.values
    n = 4001 if kind == "impulse" else 120_001
    sensors = [("displacement", 1, "x"), ("force", 1, "x")]
    err, z = [], []
    for run in range(runs):
        traces = []
        for rep in range(5):
            if kind == "impulse":
                f = np.zeros(n)
                f[0] = 100.0
            else:
                f = 10.0 * np.random.default_rng(2_000_000 + 10 * run + rep).standard_normal(n)
            response = {"displacement": offset + oscillator_displacement(model, f)[:, None], "force": f[:, None]}
            traces.append(memory_trace(model, response, DT, sensors, NOISE, seed=10 * run + rep, name=f"r{rep}.h5"))
        result = identify(traces, model)
        err.append(result.values() / truth - 1)
        z.append((result.values() - truth) / np.array([p.std_error for p in result.parameters]))
    err, z = np.abs(np.array(err)), np.abs(np.array(z))
    for j, p in enumerate(result.parameters):
        print(f"1-DOF {kind} (5 x {(n - 1) * DT:g} s, offset {offset:g} m), {p.label:12s}: "
              f"median |error| {100 * np.median(err[:, j]):.3f} %, "
              f"largest {100 * err[:, j].max():.3f} %, 95 % coverage {np.mean(z[:, j] < 1.96):.3f} over {runs} runs")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20, help="noise seeds per chapter 3 case")
    parser.add_argument("--runs", type=int, default=200, help="Monte Carlo runs per oscillator case")
    parser.add_argument("--offset", type=float, default=0.0, help="constant added to the oscillator's position, m")
    parser.add_argument("--cases", nargs="*", default=["beam-displacement", "beam-velocity", "impulse", "random"])
    args = parser.parse_args()
    for case in args.cases:
        if case.startswith("beam-"):
            beam_case(case.split("-")[1], args.seeds)
        else:
            oscillator_case(case, args.runs, args.offset)


if __name__ == "__main__":
    main()
