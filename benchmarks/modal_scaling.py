"""Time and peak memory of the modal method on one hour at 100 Hz from 100
channels (360,000 samples each): a 100-point simply supported beam with its
15 lowest modes (campaigns/ch5-damped.toml's damping ratios) under an
unmeasured band-limited random force, 2 % sensor noise, identified from
in-memory traces. Run it on the target machine size (2 cores): the time
covers covariances, subspace, stabilisation and the jackknife errors.

    python benchmarks/modal_scaling.py [--channels 100] [--seconds 3600]
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
    args = parser.parse_args(argv)
    base: ModalModel = load_campaign(CAMPAIGNS / "ch5-damped.toml").true_model
    points = np.arange(1, args.channels + 1) * 10.0 / (args.channels + 1)
    model = dataclasses.replace(base, points=points)
    dt = 0.01
    n = int(round(args.seconds / dt))
    response = modal_response(model, dt, n, 1, force=band_force(n, dt, (0.0, 30.0), 1.0, 1))
    traces = [trace(model, response, dt, "velocity", 0.02, 2)]
    del response
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    t0 = time.perf_counter()
    result = modal.identify(traces, model)
    elapsed = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    w = np.array(result.omega)
    errors = [100 * np.min(np.abs(w - e)) / e for e in model.omega[:10]]
    print(f"{args.channels} channels x {n} samples ({args.seconds:g} s at {1 / dt:g} Hz): identified in "
          f"{elapsed:.1f} s; peak resident memory {peak:.0f} MiB (before the identification {before:.0f} MiB, "
          f"the traces alone {args.channels * n * 8 / 2**20:.0f} MiB)")
    print(f"{len(w)} modes; block rows {result.details['block_rows']}, columns {result.details['block_columns']}, "
          f"references {result.details['references']}; errors of modes 1-10 (%): "
          + ", ".join(f"{e:.3f}" for e in errors))


if __name__ == "__main__":
    main()
