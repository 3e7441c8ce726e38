"""CPU time of the FRF estimate (structbench.identifier.frf.estimate) of 100
response channels x 360,000 samples per one force: Welch segments (Hann,
50 % overlap), H1, coherence and bands.

The record is synthetic (a white force; each response the force through a
random lightly damped second-order filter plus 5 % noise) and held in
memory as a :class:`~structbench.identifier.io.traces.Trace`: what is timed
is the estimate, not the reading of a file. CPU time (``time.process_time``,
every thread of the process) is the figure, as the machine is shared; wall
time is printed beside it. Target: at most 5 s.

    python benchmarks/frf_speed.py [--channels 100] [--samples 360000] [--segment 4096] [--repeat 3]

Measured (e7ea14a, 2026-11-26, 2 cores at load average 8.6 from other
jobs, medians of 3): 4096-sample segments (174 averages, 2049 lines) CPU
0.61 s, wall 0.94 s; the estimator's default segment for this record,
16384 samples (``--segment 0``: 42 averages, 8193 lines), CPU 0.79 s, wall
1.17 s. Target met. Before (2e7bcb6): 0.70 s and 1.1-1.4 s CPU when the
other core was idle, but 14-68 s CPU with 16384-sample segments when it was
busy: Welch's overlap factor then came from ``np.correlate`` of the window
(O(L^2) OpenBLAS dot products, all of that time in it by cProfile; long
ones apparently threaded and waiting for the busy core, as 4096-sample
segments were never slow); now an FFT.
"""
from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np
from scipy.signal import lfilter

from structbench.identifier.frf import estimate
from structbench.identifier.io.traces import Channel, Trace

DT = 0.01  # s


def record(channels: int, samples: int, seed: int = 0) -> Trace:
    """A random test: one force, ``channels`` acceleration-like responses."""
    rng = np.random.default_rng(seed)
    force = rng.standard_normal(samples)
    data = {"force_1_x": Channel("force_1_x", force, "force", "N", 1, "x", np.full(3, np.nan))}
    for i in range(channels):
        radius, angle = 0.995, rng.uniform(0.05, 3.0)  # a pole pair of the sampled system
        x = lfilter([1.0, -1.0], [1.0, -2 * radius * np.cos(angle), radius**2], force)
        x += 0.05 * np.std(x) * rng.standard_normal(samples)
        name = f"acceleration_{i + 2}_x"
        data[name] = Channel(name, x, "acceleration", "m/s^2", i + 2, "x", np.full(3, np.nan))
    return Trace(path=Path("speed.h5"), time=np.arange(samples) * DT, dt=DT, step=DT, channels=data,
                 excitation={}, attrs={"test": "random"}, excitation_attrs={"kind": "random"})


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--channels", type=int, default=100)
    parser.add_argument("--samples", type=int, default=360_000)
    parser.add_argument("--segment", type=int, default=4096, help="Welch segment, samples (0: the default)")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    trace = record(args.channels, args.samples)
    load = os.getloadavg()[0]
    segment = args.segment * DT if args.segment else None
    cpu, wall = [], []
    for _ in range(args.repeat):
        c0, w0 = time.process_time(), time.perf_counter()
        frf = estimate([trace], "H1", segment=segment)
        cpu.append(time.process_time() - c0)
        wall.append(time.perf_counter() - w0)
    print(f"{args.channels} channels x {args.samples} samples, segments of {frf.segment} samples, "
          f"{frf.n_averages[0]} averages, {frf.frequency.size} lines")
    print(f"CPU time median {np.median(cpu):.2f} s (min {min(cpu):.2f} s), wall median {np.median(wall):.2f} s "
          f"over {args.repeat} runs (target: CPU <= 5 s); load average {load:.1f} -> {os.getloadavg()[0]:.1f} "
          f"on {os.cpu_count()} CPUs")


if __name__ == "__main__":
    main()
