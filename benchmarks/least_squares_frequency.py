"""Frequency-domain least squares (identifier/least_squares/frequency.py) on
the chapter 3 beam from a random test, beside the time-domain estimator.

The test: a band-limited Gaussian force (white noise cut to 1-100 rad/s by
FFT, 1 N RMS, a new realisation per repetition: seed 3_000_000 + r) at node
7 (w), held over each sample, dt = 0.02 s (Nyquist 157 rad/s; the beam's
highest mode 74 rad/s: the band is far from "far below Nyquist", so the
prefiltered time-domain path refuses displacement- or velocity-only
records), ``--samples`` per repetition (default 32768, 655 s),
``--repetitions`` repetitions (default 100). Every DOF carries a
displacement, a velocity and an acceleration sensor and the force a load
cell, each with 2 % rms-mode noise (declared; numpy Generator seed r). The
response is exact (modal coordinates, each mode's zero-order hold through
``scipy.signal.lfilter``, benchmarks/frf_accuracy.py), in-memory traces.

Structures: ``ch3-free-free-beam`` (campaigns/ch3.toml's beam: undamped,
30 unknown masses and stiffnesses; its random response never becomes
stationary, so FRF lines leak) and ``ch3-damped-beam`` (element damping
``c = 0.05 k``, 45 unknowns).

Cases (``--cases``):

- ``time``: the time-domain estimator (domain=time, bias-compensated) from
  every quantity measured (the equations hold at every sample exactly);
- ``displacement``, ``velocity``, ``acceleration``: the frequency domain
  from that quantity only (domain=auto picks it for the first two).

For each case: one identification from all repetitions pooled (wall and
CPU time: the target is <= 10 s on 2 cores) and, with ``--per-repetition``,
one per repetition on ``--jobs`` processes (wall time; median normalized
RMS parameter error with its 10-90 % spread; coverage of the 95 % intervals).

    python benchmarks/least_squares_frequency.py [--structures ...] [--repetitions 100] [--samples 32768]
        [--cases time displacement velocity acceleration] [--per-repetition] [--jobs 2] [--repeat 1]

Measured on the final code (c45fbe2, 2026-11-26; Welch segments of 8192
samples, frequency_data.MAX_SEGMENT; ``--repeat 3``, medians; the default
BLAS threads, 2; a 2-core machine shared with other jobs at load average
10-12, so wall times are about 1.5 x the CPU times: one thread does the
work), 100 repetitions pooled into one identification, the frequency domain:

    ch3-damped-beam    velocity only      normalized RMS 0.00090, CPU 4.38 s (wall 6.79 s), 1169 lines, coverage 0.978
                       acceleration only  0.00048, CPU 6.75 s (wall 10.33 s; fastest of 3: CPU 6.32 s,
                                          wall 9.34 s), 2584 lines, coverage 0.756
                       displacement only  0.0206, CPU 2.26 s (wall 3.82 s): 111 lines with coherence >= 0.5
                                          (the rigid-body drift dominates each displacement's RMS, so its
                                          2 % noise buries the flexible response)
    ch3-free-free-beam velocity only      0.00531, CPU 2.91 s (wall 4.53 s); acceleration only 0.00805,
                                          CPU 3.70 s (wall 5.77 s); displacement only 0.00978, CPU 1.86 s
                                          (wall 2.86 s) (undamped: the response is never stationary and
                                          the FRF lines leak; bias dominates)

The same figures of accuracy as before the speed-up (2e7bcb6: 0.00090 /
0.00048 / 0.0206 and 0.0053 / 0.0081 / 0.0098; values equal to 4e-12,
standard errors to 1e-9, relative); its CPU times then were 7.0-7.7 s
(damped, velocities) and 11.3-12.8 s (accelerations) with one BLAS thread,
and 49.8 s CPU, 67 s wall for accelerations with the default two at load
9-10 (docs/least-squares-method.md says why).

Leakage sets the floor (measured before the speed-up): with 4096-sample
segments the same runs gave 0.00206 / 0.00111 / 0.054 (damped; CPU 5.6 /
7.5 / 2.3 s) and 0.0095 / 0.0079 / 0.025 (undamped); 20 repetitions with
16384-sample segments, velocities: 0.00055 (damped, CPU 10.9 s), 0.0030
(undamped, CPU 6.4 s).

Per repetition (one 655 s record each, repetitions 0-9, ch3-damped-beam):
frequency domain from velocities median 0.0080 (p10 0.0069, p90 0.0088),
coverage 1.000 (its standard errors carry the leakage seen in the line
variances: too wide; the same on the final code: 0.00802, 0.00694, 0.00879;
from accelerations 0.00407, p10 0.00336, p90 0.00495, coverage 0.969); the time domain from every quantity median 0.0072
(p10 0.0024, p90 0.85), coverage 0.787. The chapter 3 harmonic test's
displacement- and velocity-only figures (0.00218, 0.00134) stay with the
time domain, which ``auto`` keeps for them (band far below Nyquist).
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from multiprocessing import Pool
from pathlib import Path

import numpy as np
from scipy.signal import lfilter

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from frf_accuracy import modal_system, mode_filters  # noqa: E402
from identify_synth import UNITS  # noqa: E402
from structbench.identifier.io.traces import Channel, Trace  # noqa: E402
from structbench.identifier.least_squares import identify  # noqa: E402
from structbench.models import load_model  # noqa: E402

DT = 0.02
BAND = (1.0, 100.0)
NOISE = 0.02
FORCE = (7, "w")
QUANTITIES = ("displacement", "velocity", "acceleration")


def band_force(n: int, seed: int) -> np.ndarray:
    x = np.random.default_rng(seed).standard_normal(n)
    X = np.fft.rfft(x)
    w = 2 * np.pi * np.fft.rfftfreq(n, DT)
    X[(w < BAND[0]) | (w > BAND[1])] = 0.0
    x = np.fft.irfft(X, n)
    return x / np.sqrt(np.mean(x**2))


def simulate(system, j: int, force: np.ndarray) -> dict[str, np.ndarray]:
    """Displacement, velocity, acceleration (n_dof, N) under ``force`` at DOF ``j`` (exact ZOH)."""
    phi, omega, zeta = system
    q, v, a = (np.empty((omega.size, force.size)) for _ in range(3))
    for r in range(omega.size):
        g = phi[j, r] * force
        b_q, b_v, den = mode_filters(omega[r], zeta[r], DT)
        q[r], v[r] = lfilter(b_q, den, g), lfilter(b_v, den, g)
        a[r] = g - omega[r] ** 2 * q[r] - 2 * zeta[r] * omega[r] * v[r]
    return {"displacement": phi @ q, "velocity": phi @ v, "acceleration": phi @ a}


def repetition(model, system, rep: int, samples: int) -> dict[str, Channel]:
    """Every channel of repetition ``rep`` (noisy, declared 2 % rms)."""
    j = model.dofs.index(FORCE)
    force = band_force(samples, 3_000_000 + rep)
    clean = simulate(system, j, force) | {"force": force[None, :]}
    rng = np.random.default_rng(rep)
    out = {}
    for quantity in QUANTITIES + ("force",):
        dofs = [FORCE] if quantity == "force" else model.dofs
        for k, (node, direction) in enumerate(dofs):
            x = clean[quantity][k]
            data = x + NOISE * np.sqrt(np.mean(x**2)) * rng.standard_normal(x.size)
            name = f"{quantity}_{node}_{direction}"
            out[name] = Channel(name, data, quantity, UNITS[quantity][direction == "theta"], node, direction,
                                np.full(3, np.nan), NOISE, "rms")
    return out


def trace(channels: dict[str, Channel], keep: tuple[str, ...], rep: int, model) -> Trace:
    chans = {k: c for k, c in channels.items() if c.quantity in keep + ("force",)}
    n = next(iter(chans.values())).data.size
    return Trace(path=Path(f"random.r{rep:03d}.h5"), time=np.arange(n) * DT, dt=DT, step=DT, channels=chans,
                 excitation={}, attrs={"test": "random", "repetition": rep, "structure": model.name},
                 excitation_attrs={"kind": "random"})


CASES = {"time": (QUANTITIES, "time"), "displacement": (("displacement",), "frequency"),
         "velocity": (("velocity",), "frequency"), "acceleration": (("acceleration",), "frequency")}


def score(result, truth: np.ndarray) -> tuple[float, np.ndarray]:
    values = result.values()
    std = np.array([p.std_error for p in result.parameters])
    return float(np.sqrt(np.mean((values / truth - 1) ** 2))), (values - truth) / std


_STATE: dict = {}


def _one(args: tuple) -> tuple[float, np.ndarray, float, str]:
    name, keep, domain, rep = args
    model, traces = _STATE["model"], _STATE["traces"]
    start = time.perf_counter()
    result = identify([trace(traces[rep], keep, rep, model)], model, domain=domain)
    rms, z = score(result, model.values[model.kind_mask()])
    return rms, z, time.perf_counter() - start, result.details["domain"]["chosen"]


def run(structure: str, args: argparse.Namespace) -> None:
    model = load_model(structure)
    system = modal_system(structure)[:3]
    start = time.perf_counter()
    channels = [repetition(model, system, r, args.samples) for r in range(args.repetitions)]
    print(f"{structure}: {args.repetitions} repetitions x {args.samples} samples at dt {DT} s simulated in "
          f"{time.perf_counter() - start:.0f} s; {int(model.kind_mask().sum())} unknowns", flush=True)
    truth = model.values[model.kind_mask()]
    _STATE.update(model=model, traces=channels)
    for case in args.cases:
        keep, domain = CASES[case]
        traces = [trace(c, keep, r, model) for r, c in enumerate(channels)]
        if not args.no_pooled:
            load = os.getloadavg()[0]
            walls, cpus = [], []
            try:
                for _ in range(args.repeat):  # the same identification, timed again (load varies)
                    wall, cpu = time.perf_counter(), time.process_time()
                    result = identify(traces, model, domain=domain)
                    walls.append(time.perf_counter() - wall)
                    cpus.append(time.process_time() - cpu)
            except Exception as err:  # a refusal is a figure too
                print(f"  {case:12s} pooled: {type(err).__name__}: {err}", flush=True)
            else:
                wall, cpu = np.median(walls), np.median(cpus)
                rms, z = score(result, truth)
                fd = result.details.get("frequency_domain", {})
                spread = (f" (median of {args.repeat}; min {min(walls):.2f} / {min(cpus):.2f} s)"
                          if args.repeat > 1 else "")
                print(f"  {case:12s} pooled ({result.details['domain']['chosen']}): normalized RMS {rms:.5f}, "
                      f"95 % coverage {np.mean(np.abs(z) < 1.96):.3f}, wall {wall:.2f} s, CPU {cpu:.2f} s{spread} "
                      f"(load {load:.1f} -> {os.getloadavg()[0]:.1f})"
                      + (f"; {fd.get('lines')} lines, {fd.get('zoh_corrections')} ZOH passes" if fd else ""),
                      flush=True)
        if args.per_repetition:
            wall = time.perf_counter()
            jobs = [(structure, keep, domain, r) for r in range(args.repetitions)]
            with Pool(args.jobs) as pool:
                rows = pool.map(_one, jobs)
            wall = time.perf_counter() - wall
            rms = np.array([r[0] for r in rows])
            z = np.array([r[1] for r in rows])
            p10, med, p90 = np.percentile(rms, [10, 50, 90])
            print(f"  {case:12s} per repetition ({rows[0][3]}): normalized RMS median {med:.5f} (p10 {p10:.5f}, "
                  f"p90 {p90:.5f}), 95 % coverage {np.mean(np.abs(z) < 1.96):.3f}; {len(rows)} identifications "
                  f"on {args.jobs} processes in {wall:.1f} s wall", flush=True)


def blas_threads() -> str:
    """The BLAS libraries' thread counts (as found, nothing set)."""
    from threadpoolctl import threadpool_info
    return ", ".join(f"{i['internal_api']} {i['version']} {i['num_threads']}" for i in threadpool_info()
                     if i["user_api"] == "blas")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--structures", nargs="+", default=["ch3-free-free-beam", "ch3-damped-beam"])
    parser.add_argument("--repetitions", type=int, default=100)
    parser.add_argument("--samples", type=int, default=32768)
    parser.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    parser.add_argument("--per-repetition", action="store_true", help="also one identification per repetition")
    parser.add_argument("--no-pooled", action="store_true", help="skip the pooled identification")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--repeat", type=int, default=1, help="time each pooled identification this many times")
    args = parser.parse_args()
    print(f"{os.cpu_count()} CPUs, BLAS threads: {blas_threads()}; load average {os.getloadavg()[0]:.1f}", flush=True)
    for structure in args.structures:
        run(structure, args)


if __name__ == "__main__":
    main()
