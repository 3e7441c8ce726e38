"""``structbench score``: compare a campaign's results with its truth."""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from structbench import api

HELP = "score results/*.json of a campaign folder against truth.json"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("campaign_dir", type=Path, metavar="CAMPAIGN_DIR")
    parser.add_argument("--json", action="store_true", help="print the scores as JSON")


def _fmt(values: list[float], digits: int = 2) -> str:
    return " ".join(f"{v:+.{digits}f}" for v in values)


def run(args: argparse.Namespace) -> int:
    scores = api.score(args.campaign_dir)
    if args.json:
        print(json.dumps(scores, indent=1))
        return 0
    for stem, score in scores.items():
        s = score["summary"]
        print(f"{stem} ({score['method']}, {s['runs']} run(s))")
        if "rms" in s:
            print(f"  normalized RMS parameter error: median {s['rms']['median']:.4g} "
                  f"(10-90 %: {s['rms']['p10']:.4g} .. {s['rms']['p90']:.4g})")
        if "rms_initial" in s:
            print(f"  starting model: median {s['rms_initial']['median']:.4g}; improved in "
                  f"{100 * s['improved_fraction']:.0f} % of runs; iterations {s['iterations']}")
        if s.get("freq_error_pct_median"):
            print(f"  frequency error (%), median per mode: {_fmt(s['freq_error_pct_median'])}")
        if s.get("mac_median"):
            print(f"  MAC, median per mode: {' '.join(f'{v:.3f}' for v in s['mac_median'])}")
    return 0
