"""``structbench export``: a campaign's traces as UFF 58, CSV or SEP005 files,
or its modal results as one UFF 55 file.

One file per trace plus ``sensor-map.toml``; ``structbench import FILES
--map sensor-map.toml`` gives the traces back (binary UFF bit for bit).
``--format uff55 --out FILE``: the modes of ``DIR/results/`` (docs/labdata.md).
"""
from __future__ import annotations

import argparse
from pathlib import Path

from structbench import api

HELP = ("export a campaign's traces to UFF 58 (binary or --ascii), CSV or SEP005 JSON files, or its modal "
        "results to UFF 55")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("campaign_dir", type=Path, metavar="DIR", help="campaign folder (DIR/traces/*.h5)")
    parser.add_argument("--format", required=True, choices=["uff58", "csv", "sep005", "uff55"])
    parser.add_argument("--out", type=Path, required=True, metavar="PATH",
                        help="folder for the files (uff55: the file)")
    parser.add_argument("--results", metavar="STEM", help="uff55: results/STEM.json (default: the only one with "
                                                          "mode shapes)")
    parser.add_argument("--ascii", action="store_true", help="UFF 58 as ASCII (default binary)")


def run(args: argparse.Namespace) -> int:
    if args.format == "uff55":
        path = api.export_modes(args.campaign_dir, args.out, args.results)
        print(f"modes as UFF 55 in {path}")
        return 0
    written = api.export_traces(args.campaign_dir, args.format, args.out, binary=not args.ascii)
    print(f"{len(written)} {args.format} file(s) and sensor-map.toml in {args.out}")
    return 0
