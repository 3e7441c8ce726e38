"""Least squares with unmeasured DOF (identifier/least_squares/unmeasured.py):
the chapter 3 beam measured by transverse sensors only, its rotations never.

The test of benchmarks/least_squares_frequency.py (band-limited random force
1-100 rad/s, 1 N RMS, at node 7 (w), held over each sample, dt = 0.02 s,
``--samples`` per repetition, default 32768 = 655 s; force seed 3_000_000 +
r; 2 % rms-mode noise on every channel, declared, numpy Generator seed r;
exact modal zero-order-hold responses), with the sensors of one quantity at
the 16 transverse DOF only (``dirs = ["w"]``) and the load cell. The model
handed to the identifier is the structure's topology (every unknown value
1.0, as ``structbench identify`` gives it: no prior value), so the start is
the method's own. One identification per repetition (one record); for each
structure and quantity: median normalized RMS parameter error with its
10-90 % spread, the coverage of the 95 % intervals over every parameter and
repetition, the number of undetermined parameters, CPU time per
identification (single-threaded BLAS).

    python benchmarks/least_squares_unmeasured.py [--structures ch3-damped-beam] [--quantities velocity]
        [--first 0] [--repetitions 20] [--samples 32768] [--jobs 2]

Seeds (repetitions) 0-4 were used while choosing the start's constants and
0-2 (with 100-102) for the Welch segment of the unmeasured-DOF path (a
quarter record); repetitions 200-219 were run once on the final code:

    ch3-damped-beam, transverse velocity only, repetitions 200-219: normalized RMS median 0.00753
        (p10 0.00625, p90 0.00975); 95 % coverage 0.967 over 900 intervals (RMS of error / standard
        error 0.98); undetermined 0; CPU per identification median 13.2 s (max 17.1 s);
        bias RMS 0.00578, spread 0.00593
    ch3-damped-beam, transverse acceleration only, repetitions 200-219: median 0.00264 (p10 0.00188,
        p90 0.00323); coverage 0.944 (RMS 1.03); CPU median 14.3 s (max 16.4 s); bias 0.00129,
        spread 0.00232

(a 2-core machine at load about 20: CPU time, single-threaded BLAS, is the
speed figure). Before the quarter-record segments (the FRF default, 1/16),
repetitions 100-119 from velocities: median 0.0288 (p10 0.0250, p90
0.0316), coverage 1.000, CPU 3.0 s; repetitions 100-109: bias 0.0276, spread
0.0083; the same records with every DOF measured (full-DOF frequency
domain, same segments): bias 0.0073, spread 0.0028.

Displacements only: few coherent lines (rigid-body drift buries the
flexible response). Before the support rule (unmeasured_support.py), tuning
repetitions 0-9: 44-139 lines in 7-20 clusters for 45 unknowns, normalized
RMS 0.17-1.15, coverage per repetition 0.82-1.00 (RMS of error / standard
error 0.30-1.84), the cost per degree of freedom 0.57-0.71 (velocities
0.61-0.63: the misfit test does not tell them apart); velocities 878/883
lines in 141/142 clusters (repetitions 0, 1), accelerations 2585 in 325
(repetition 0). With the rule (no more clusters than determined parameters:
refused), repetitions 0-19 and fresh 300-309: displacements refused 20/20
and 10/10; fresh 300-309 (run once):

    velocity: refused 0/10; median 0.00699 (p10 0.00541, p90 0.00836); coverage 0.973 over 450
        (RMS 0.92); CPU median 11.4 s; bias RMS 0.00489, spread 0.00591
    acceleration: refused 0/10; median 0.00262 (p10 0.00233, p90 0.00307); coverage 0.942 over 450
        (RMS 1.02); CPU median 13.9 s; bias RMS 0.00149, spread 0.00233

Displacements with --samples 131072 (repetitions 0-1): refused 2/2 (the
zero-order-hold correction's first estimate, cost per degree of freedom
16.5, is not a stable structure).
"""
from __future__ import annotations

import argparse
import sys
import time
from multiprocessing import Pool
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from frf_accuracy import modal_system  # noqa: E402
from least_squares_frequency import repetition, trace  # noqa: E402
from structbench.dispatch.runs import topology  # noqa: E402
from structbench.identifier.errors import IdentificationError  # noqa: E402
from structbench.identifier.least_squares import identify  # noqa: E402
from structbench.models import load_model  # noqa: E402

_STATE: dict = {}


def _one(args: tuple) -> tuple:
    quantity, rep = args
    model, system, samples = _STATE["model"], _STATE["system"], _STATE["samples"]
    channels = repetition(model, system, rep, samples)
    kept = {k: c for k, c in channels.items() if c.quantity == "force" or c.direction == "w"}
    with threadpool_limits(1):
        start = time.process_time()
        try:
            result = identify([trace(kept, (quantity,), rep, model)], topology(model))
        except IdentificationError as error:
            return None, str(error), time.process_time() - start, 0, None
        cpu = time.process_time() - start
    truth = model.values[model.kind_mask()]
    values = result.values()
    std = np.array([np.nan if p.std_error is None else p.std_error for p in result.parameters])
    ok = np.isfinite(values)
    rms = float(np.sqrt(np.mean((values[ok] / truth[ok] - 1) ** 2)))
    return rms, (values - truth) / std, cpu, int(np.sum(~ok)), values / truth - 1


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--structures", nargs="+", default=["ch3-damped-beam"])
    parser.add_argument("--quantities", nargs="+", default=["velocity"],
                        choices=["displacement", "velocity", "acceleration"])
    parser.add_argument("--first", type=int, default=100, help="first repetition (seed)")
    parser.add_argument("--repetitions", type=int, default=20)
    parser.add_argument("--samples", type=int, default=32768)
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    for structure in args.structures:
        model = load_model(structure)
        _STATE.update(model=model, system=modal_system(structure)[:3], samples=args.samples)
        for quantity in args.quantities:
            reps = range(args.first, args.first + args.repetitions)
            wall = time.perf_counter()
            with Pool(args.jobs) as pool:
                rows = pool.map(_one, [(quantity, r) for r in reps])
            wall = time.perf_counter() - wall
            refused = [r[1] for r in rows if r[0] is None]
            rows = [r for r in rows if r[0] is not None]
            print(f"{structure}, transverse {quantity} only: refused {len(refused)} of {len(reps)}"
                  + (f" (... {refused[0].split('refused: ')[-1]})" if refused else ""), flush=True)
            if not rows:
                continue
            rms = np.array([r[0] for r in rows])
            z = np.concatenate([r[1] for r in rows])
            cpu = np.array([r[2] for r in rows])
            p10, med, p90 = np.percentile(rms, [10, 50, 90])
            print(f"{structure}, transverse {quantity} only, repetitions {reps.start}-{reps.stop - 1}: normalized "
                  f"RMS median {med:.5f} (p10 {p10:.5f}, p90 {p90:.5f}); 95 % coverage "
                  f"{np.mean(np.abs(z[np.isfinite(z)]) < 1.96):.3f} over {np.isfinite(z).sum()} intervals "
                  f"(RMS of error / standard error {np.sqrt(np.mean(z[np.isfinite(z)] ** 2)):.2f}); "
                  f"undetermined {sum(r[3] for r in rows)}; CPU per identification median {np.median(cpu):.1f} s "
                  f"(max {cpu.max():.1f} s); {wall:.0f} s wall on {args.jobs} processes", flush=True)
            rel = np.array([r[4] for r in rows])  # (repetitions, unknowns)
            bias, spread = np.nanmean(rel, axis=0), np.nanstd(rel, axis=0, ddof=1)
            print("  per parameter over the repetitions: RMS of the mean relative error "
                  f"{np.sqrt(np.mean(bias**2)):.5f}, RMS of the spread {np.sqrt(np.mean(spread**2)):.5f}", flush=True)


if __name__ == "__main__":
    main()
