"""Bias-compensated least squares (the default estimator): time and peak
memory against the number of samples and the model size.

1. The chapter 3 beam (32 DOF, 30 unknowns): ``REPS`` repetitions x 4,000
   samples, the exact response (zero-order hold) to 0.1 cos(t) N at node 7
   with 2 % (rms) noise on accelerations and force, identified one
   repetition after the other (memory does not grow with the repetitions).
2. Nonuniform free-free beams of 15, 150 and 1,500 elements: a smooth
   motion (sum of sines per DOF) with the forces that satisfy the
   equations of motion exactly at every DOF, 2 % noise on every channel,
   for 1,000 and 10,000 samples.

Only the identification (:func:`identifier.least_squares.bias_compensated.solve_compensated`)
is timed; peak memory is what tracemalloc sees allocated during it (the
motion arrays themselves, 8 x samples x DOF floats, are listed apart).

BLAS runs single-threaded here (``OPENBLAS_NUM_THREADS=1`` unless set): the
matrices of a 32-DOF model are too small for threads to pay, and two worker
processes use the two cores instead.

    python benchmarks/least_squares_scaling.py [--quick]
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import resource  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import tracemalloc  # noqa: E402
from concurrent.futures import ProcessPoolExecutor  # noqa: E402

import numpy as np  # noqa: E402

from structbench.identifier.least_squares.bias_compensated import solve_compensated  # noqa: E402
from structbench.identifier.least_squares import Motion  # noqa: E402
from structbench.models import load_model  # noqa: E402
from structbench.models.library import beam  # noqa: E402

REPS = 100
RATIO = 0.02


def noisy(clean: dict[str, np.ndarray], quantities: tuple[str, ...], rng: np.random.Generator) -> Motion:
    sigma, data = {}, {}
    for q, x in clean.items():
        s = RATIO * np.sqrt(np.mean(x**2, axis=0)) if q in quantities else np.zeros(x.shape[1])
        data[q] = x + s * rng.standard_normal(x.shape)
        sigma[q] = np.broadcast_to(s, x.shape)
    return Motion(np.arange(x.shape[0], dtype=float), data["displacement"], data["velocity"],
                  data["acceleration"], data["force"], sigma)


def ch3_errors(reps: int, seed: int) -> list[float]:
    """Normalized RMS errors of ``reps`` noisy repetitions (numpy Generator ``seed``)."""
    model = load_model("ch3-free-free-beam")
    dt, n = 0.001, 4000
    t = np.arange(n + 1) * dt
    force = np.zeros((t.size, model.n_dof))
    force[:, model.dof_index(7, "w")] = 0.1 * np.cos(t)
    out = model.state_space().simulate(force, dt)
    clean = {q: out[q][1:] for q in ("displacement", "velocity", "acceleration")} | {"force": force[1:]}
    rng = np.random.default_rng(seed)
    truth = model.values[model.kind_mask()]
    rms = []
    for _ in range(reps):
        est = solve_compensated(model, noisy(clean, ("acceleration", "force"), rng))
        rms.append(float(np.sqrt(np.mean((est.values / truth - 1) ** 2))))
    return rms


def ch3(reps: int, workers: int) -> str:
    """The chapter 3 beam, 4,000 samples: ``reps`` repetitions over ``workers`` processes
    (simulation, noise and identification all timed)."""
    start, cpu = time.perf_counter(), time.process_time()
    if workers == 1:
        rms = ch3_errors(reps, 11)
    else:
        share = [reps // workers + (i < reps % workers) for i in range(workers)]
        with ProcessPoolExecutor(workers) as pool:
            rms = [r for part in pool.map(ch3_errors, share, range(11, 11 + workers)) for r in part]
    elapsed, cpu = time.perf_counter() - start, time.process_time() - cpu
    used = f", CPU time of this process {cpu:.2f} s" if workers == 1 else ""
    return (f"ch3 beam, 32 DOF: {reps} repetitions x 4000 samples on {workers} process(es) in {elapsed:.2f} s"
            f"{used}; median normalized RMS {np.median(rms):.5f}; load average {os.getloadavg()[0]:.1f}")


def nonuniform_beam(n: int):
    rng = np.random.default_rng(n)
    return beam(f"free-free-{n}", list(np.round(rng.uniform(1.0, 8.5, n), 1)),
                list(np.round(rng.uniform(1.0, 6.6, n), 1)), float(n))


def smooth_motion(model, samples: int, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """u = sum_i sin(w_i t + phi_i) per DOF (3 sines, 0.5-3 rad/s), v, a exact, f = M a + K u."""
    t = np.arange(samples) * 1e-3 * (4000 / samples)
    u, v, a = (np.zeros((samples, model.n_dof)) for _ in range(3))
    for _ in range(3):
        w, phi = rng.uniform(0.5, 3.0, model.n_dof), rng.uniform(0, 2 * np.pi, model.n_dof)
        arg = np.outer(t, w) + phi
        u += np.sin(arg)
        v += w * np.cos(arg)
        a -= w**2 * np.sin(arg)
    f = (model.mass() @ a.T + model.damping() @ v.T + model.stiffness() @ u.T).T
    return {"displacement": u, "velocity": v, "acceleration": a, "force": f}


def large(elements: int, samples: int) -> str:
    model = nonuniform_beam(elements)
    rng = np.random.default_rng(elements + samples)
    quantities = ("displacement", "velocity", "acceleration", "force")
    motion = noisy(smooth_motion(model, samples, rng), quantities, rng)
    data_mb = 8 * 8 * samples * model.n_dof / 1e6
    truth = model.values[model.kind_mask()]
    tracemalloc.start()
    start = time.perf_counter()
    est = solve_compensated(model, motion)
    elapsed = time.perf_counter() - start
    peak = tracemalloc.get_traced_memory()[1] / 1e6
    tracemalloc.stop()
    rms = np.sqrt(np.mean((est.values / truth - 1) ** 2))
    return (f"{elements:5d} elements ({model.n_dof:5d} DOF, {truth.size:5d} unknowns) x {samples:6d} samples: "
            f"{elapsed:7.2f} s, peak {peak:7.1f} MB (+ motion {data_mb:.0f} MB), normalized RMS {rms:.2e}")


def main(argv: list[str]) -> None:
    quick = "--quick" in argv
    for workers in (1, 2):
        print(ch3(10 if quick else REPS, workers), flush=True)
    for elements in (15, 150) if quick else (15, 150, 1500):
        for samples in (1000, 10000):
            print(large(elements, samples), flush=True)
    print(f"peak resident memory of this process: {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6:.2f} GB")


if __name__ == "__main__":
    main(sys.argv[1:])
