"""Steps per second driving the 32-DOF ch3-free-free-beam FMU: all 32 inputs set
and all 96 outputs read each step, 10,000 steps.

(a) FmuSession.run (the harness loop), (b) fmpy.simulate_fmu with
output_interval = step and an input table, (c) a plain numpy loop of the same
discrete model. Usage: python benchmarks/fmu_throughput.py [--steps N]

(b) runs in a process of its own: fmpy unloads the FMU's binary after
simulate_fmu, and with a second copy of pythonfmu's binary loaded in the same
process (the session's) the interpreter intermittently aborts at exit.
"""
from __future__ import annotations

import argparse
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from typing import Callable

import numpy as np
from fmpy import simulate_fmu

from structbench.harness.fmu_session import FmuSession
from structbench.models import load_model
from structbench.fmus import build_fmu


def timed(fn: Callable[[], object], repeat: int = 3) -> float:
    """Best wall time of ``repeat`` calls, s."""
    best = np.inf
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def numpy_loop(ad: np.ndarray, bd: np.ndarray, c_out: np.ndarray, d_out: np.ndarray,
               forces: np.ndarray) -> np.ndarray:
    """The same sampling as the harness: outputs at t_k with forces[k], then a ZOH step."""
    x = np.zeros(ad.shape[0])
    out = np.empty((forces.shape[0], c_out.shape[0]))
    for k, f in enumerate(forces):
        out[k] = c_out @ x + d_out @ f
        x = ad @ x + bd @ f
    return out


def time_simulate_fmu(path: str, inputs: list[str], outputs: list[str], forces: np.ndarray, dt: float) -> float:
    """Wall time of one fmpy.simulate_fmu run with the forces as an input table, s."""
    n = forces.shape[0]
    table = np.zeros(n, dtype=[("time", np.float64)] + [(name, np.float64) for name in inputs])
    table["time"] = np.arange(n) * dt
    for j, name in enumerate(inputs):
        table[name] = forces[:, j]
    return timed(lambda: simulate_fmu(path, stop_time=(n - 1) * dt, output_interval=dt,
                                      input=table, output=outputs, validate=False), repeat=1)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=10_000)
    n = parser.parse_args().steps
    dt = 1e-3
    model = load_model("ch3-free-free-beam")
    inputs = [f"F_{node}_{d}" for node, d in model.dofs]
    outputs = [f"{q}_{node}_{d}" for q in "uva" for node, d in model.dofs]
    forces = np.random.default_rng(0).normal(size=(n, model.n_dof))
    ss = model.state_space()
    ad, bd = ss.discretize(dt)
    c_out = np.vstack([ss.Cd, ss.Cv, ss.Ca])
    d_out = np.vstack([np.zeros_like(ss.Da), np.zeros_like(ss.Da), ss.Da])

    with tempfile.TemporaryDirectory() as tmp:
        path = build_fmu(model, tmp)
        with FmuSession(path) as session:
            def harness() -> np.ndarray:
                session.reset()
                return session.run(inputs, outputs, forces, dt)
            t_a = timed(harness)
            check = harness()
        with ProcessPoolExecutor(1, mp_context=get_context("spawn")) as pool:
            t_b = pool.submit(time_simulate_fmu, str(path), inputs, outputs, forces, dt).result()
    t_c = timed(lambda: numpy_loop(ad, bd, c_out, d_out, forces))
    ref = numpy_loop(ad, bd, c_out, d_out, forces)
    err = np.abs(check - ref).max() / np.abs(ref).max()

    print(f"ch3-free-free-beam FMU, {model.n_dof} inputs, {len(outputs)} outputs, {n} steps")
    for label, t in (("(a) FmuSession.run", t_a), ("(b) fmpy.simulate_fmu", t_b), ("(c) numpy loop", t_c)):
        print(f"  {label:24s} {n / t:10.0f} steps/s   ({t:.3f} s)")
    print(f"  ratio (a)/(c) = {t_a / t_c:.2f}   ratio (b)/(c) = {t_b / t_c:.2f}")
    print(f"  max relative difference (a) vs (c): {err:.1e}")


if __name__ == "__main__":
    main()
