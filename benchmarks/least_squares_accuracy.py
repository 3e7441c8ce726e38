"""Chapter 3 accuracy of least squares: the dissertation's set-up (8 sample
times, noise-weighted) beside the default (bias-compensated, whitened, every
sample), over the noise seeds of the shipped campaigns, through the public API
(``structbench.run_campaign``, ``identify``, ``score``).

Campaigns: ``ch3.toml`` (groups ``harmonic``: 2 % noise on accelerations and
force; ``noisy-displacement``: 2 % on every sensor) and ``ch3-damped.toml``
(45 unknowns with element damping), each with ``--repetitions`` noise seeds
(default 20). Prints per case the median normalized RMS error with its
10-90 % spread, per parameter kind the median |relative error| (worst
parameter's median) and the coverage of the stated 95 % intervals, and
the identification time.

    python benchmarks/least_squares_accuracy.py [--out DIR] [--repetitions N]
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import structbench as sb
from structbench.evaluation.beyond import row
from structbench.evaluation.reproduce import CAMPAIGNS, campaign_with_repetitions

CASES = (  # campaign, group, tag, options
    ("ch3", "harmonic", "m8", {"estimator": "ols", "samples": 8, "interval": 0.5}),
    ("ch3", "harmonic", "all", {}),
    ("ch3", "noisy-displacement", "m8-noisy-displacement", {"estimator": "ols", "samples": 8, "interval": 0.5}),
    ("ch3", "noisy-displacement", "all-noisy-displacement-unweighted", {"weighting": "none"}),
    ("ch3", "noisy-displacement", "all-noisy-displacement", {}),
    ("ch3-damped", "harmonic", "m8", {"estimator": "ols", "samples": 8, "interval": 0.5}),
    ("ch3-damped", "harmonic", "all", {}),
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/least-squares-accuracy"))
    parser.add_argument("--repetitions", type=int, default=20)
    args = parser.parse_args()
    for name in dict.fromkeys(c for c, *_ in CASES):
        status = sb.run_campaign(campaign_with_repetitions(CAMPAIGNS / f"{name}.toml", args.repetitions),
                                 args.out / name, jobs=1)
        assert not status.failed, f"{name}: {status.failed} test(s) failed"
    for name, group, tag, options in CASES:
        folder = args.out / name
        start = time.perf_counter()
        sb.identify(folder, "least-squares", groups=[group], tag=tag, **options)
        elapsed = time.perf_counter() - start
        r = row(sb.score(folder)[f"least-squares-{tag}"])
        rms = r["rms"]
        print(f"{name} {group} [{tag}] {options or 'default'}: normalized RMS median {rms['median']:.5f} "
              f"(p10 {rms['p10']:.5f}, p90 {rms['p90']:.5f}) over {r['runs']} seeds; {elapsed:.1f} s")
        for kind, v in r["kinds"].items():
            print(f"    {kind:9s} median |error| {100 * v['median_abs_error']:.3f} % "
                  f"(worst parameter {100 * v['worst_median_abs_error']:.3f} %), "
                  f"95 % coverage {v.get('coverage95', float('nan')):.3f}")


if __name__ == "__main__":
    main()
