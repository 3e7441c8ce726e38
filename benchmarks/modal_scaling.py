"""Time and peak memory of the modal method on one hour at 100 Hz from 100
channels (360,000 samples each): a 100-point simply supported beam with its
15 lowest modes (campaigns/ch5-damped.toml's damping ratios) under an
unmeasured band-limited random force, 2 % sensor noise, identified from
in-memory traces. Run it on the target machine size (2 cores): the time
covers covariances, subspace, stabilisation and the jackknife errors; the
memory is the process's peak (the simulation's included).

Prints the errors of modes 1-10 against the truth, in % and in units of the
stated standard errors, beside the floor a one-hour record of random
excitation sets whatever the method, ``sqrt(zeta / (omega T))`` (the
relative standard deviation of a natural frequency estimated from a record
of ``T`` s of a mode's random response). ``--forces N`` repeats the
identification for N force realisations (a new one each) and prints the
median and the 90th percentile of the absolute errors.

    python benchmarks/modal_scaling.py [--channels 100] [--seconds 3600] [--forces 1]
"""
from __future__ import annotations

import argparse
import dataclasses
import resource
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from modal_synth import band_force, modal_response, trace  # noqa: E402

from structbench.harness.campaign import load_campaign  # noqa: E402
from structbench.identifier import modal  # noqa: E402
from structbench.models import ModalModel  # noqa: E402

CAMPAIGNS = Path(__file__).resolve().parents[1] / "campaigns"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--channels", type=int, default=100)
    parser.add_argument("--seconds", type=float, default=3600.0)
    parser.add_argument("--forces", type=int, default=1)
    args = parser.parse_args(argv)
    base: ModalModel = load_campaign(CAMPAIGNS / "ch5-damped.toml").true_model
    points = np.arange(1, args.channels + 1) * 10.0 / (args.channels + 1)
    model = dataclasses.replace(base, points=points)
    dt = 0.01
    n = int(round(args.seconds / dt))
    true = model.omega[:10]
    floor = 100 * np.sqrt(model.zeta[:10] / (true * args.seconds))
    all_errors = []
    for force in range(1, args.forces + 1):
        response = modal_response(model, dt, n, 1, force=band_force(n, dt, (0.0, 30.0), 1.0, force))
        traces = [trace(model, response, dt, "velocity", 0.02, 2)]
        del response
        before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        t0, c0 = time.perf_counter(), time.process_time()
        result = modal.identify(traces, model)
        elapsed, cpu = time.perf_counter() - t0, time.process_time() - c0
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        del traces
        w, se = np.array(result.omega), np.array(result.omega_std)
        idx = [int(np.argmin(np.abs(w - e))) for e in true]
        errors = 100 * (w[idx] - true) / true
        all_errors.append(np.abs(errors))
        print(f"force {force}: {args.channels} channels x {n} samples ({args.seconds:g} s at {1 / dt:g} Hz) "
              f"identified in {elapsed:.1f} s wall, {cpu:.1f} s CPU; peak resident memory {peak:.0f} MiB "
              f"(before the identification {before:.0f} MiB, the traces alone "
              f"{args.channels * n * 8 / 2**20:.0f} MiB)")
        print(f"  {len(w)} modes; block rows {result.details['block_rows']}, columns "
              f"{result.details['block_columns']}, references {result.details['references']}")
        print("  errors of modes 1-10 (%):     " + ", ".join(f"{e:+.3f}" for e in errors))
        print("  errors / stated std:          " + ", ".join(f"{e:+.2f}" for e in (w[idx] - true) / se[idx]))
        print("  floor sqrt(zeta/(omega T)) %: " + ", ".join(f"{f:.3f}" for f in floor))
    if args.forces > 1:
        a = np.array(all_errors)
        print(f"{args.forces} force realisations, |error| % median: "
              + ", ".join(f"{e:.3f}" for e in np.median(a, 0)) + "\n  90th percentile: "
              + ", ".join(f"{e:.3f}" for e in np.percentile(a, 90, axis=0)))


if __name__ == "__main__":
    main()
