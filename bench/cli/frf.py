"""``structbench frf``: FRFs with coherence and confidence bands from a
campaign's traces (random, impulse and stepped-sine tests), one HDF5 file
and one plot per test group in ``DIR/frf/`` (docs/frf-format.md).
``structbench export DIR --format uff58`` then also writes them as UFF 58
function type 4.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from structbench import api

HELP = "frequency response functions (H1, H2, Hv) with coherence and confidence bands into DIR/frf/"
ESTIMATORS = ("H1", "H2", "Hv")  # structbench.identifier.frf.ESTIMATORS (not imported: --help stays light)
ANALYSES = ("auto", "welch", "impulse", "harmonic")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("campaign_dir", type=Path, metavar="DIR", help="campaign folder (DIR/traces/*.h5)")
    parser.add_argument("--estimator", choices=ESTIMATORS, default="H1",
                        help="H1 (noise on the response), H2 (noise on the force), Hv (both); default H1")
    parser.add_argument("--group", action="append", dest="groups", metavar="GROUP",
                        help="only this test group (repeatable; default every group with a force)")
    parser.add_argument("--response", action="append", dest="responses", metavar="CHANNEL",
                        help="only this response channel (repeatable; default every non-force sensor)")
    parser.add_argument("--force", metavar="CHANNEL", help="the force channel (needed when a test has several)")
    parser.add_argument("--analysis", choices=ANALYSES, default="auto",
                        help="welch (random), impulse, harmonic (stepped sine); default from the excitation")
    parser.add_argument("--segment", type=float, metavar="SECONDS",
                        help="Welch segment length, s (default: 2^k samples, about 1/16 of all samples)")
    parser.add_argument("--overlap", type=float, default=0.5, help="Welch segment overlap, fraction (default 0.5)")
    parser.add_argument("--window", help="scipy window name (default hann; impulse tests boxcar)")
    parser.add_argument("--blocks", type=int, default=8, help="averages per stepped-sine record (default 8)")
    parser.add_argument("--confidence", type=float, default=0.95, help="two-sided level of the bands (0.95)")
    parser.add_argument("--no-plot", action="store_true", help="write no PNG plots")
    parser.add_argument("--json", action="store_true", help="print the written files as JSON")


def run(args: argparse.Namespace) -> int:
    done = api.frf(args.campaign_dir, args.estimator, groups=args.groups, plot=not args.no_plot,
                   responses=args.responses, force=args.force, analysis=args.analysis, segment=args.segment,
                   overlap=args.overlap, window=args.window, blocks=args.blocks, confidence=args.confidence)
    if args.json:
        print(json.dumps({"files": {g: str(p) for g, p in done.files.items()},
                          "plots": {g: str(p) for g, p in done.plots.items()},
                          "warnings": {g: f.warnings for g, f in done.frfs.items() if f.warnings},
                          "skipped": done.skipped}, indent=2))
        return 0
    for group, frf in done.frfs.items():
        lines = len(frf.frequency)
        print(f"{group}: {frf.estimator} of {len(frf.responses)} response(s) per {frf.force.name}, "
              f"{frf.analysis}, {lines} line(s), {int(frf.n_averages.max())} averages -> {done.files[group]}")
        for warning in frf.warnings:
            print(f"  warning: {warning}")
    for group, reason in done.skipped.items():
        print(f"{group}: skipped ({reason})")
    return 0
