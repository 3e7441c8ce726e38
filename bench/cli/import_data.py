"""``structbench import``: measured files (UFF 58, CSV, SEP005) into a trace folder,
with the files' geometry (``geometry.json``) and modal results (UFF 55, ``results/``).

One trace per file, in SI units converted from the files' own unit fields;
the sensor map (TOML, docs/labdata.md) gives what the files lack. Every
identifier, ``score`` and ``check`` then run on the folder unchanged.
"""
from __future__ import annotations

import argparse
from pathlib import Path

from structbench import api

HELP = ("import measured data (UFF 58 ascii/binary, CSV, SEP005 JSON) into a trace folder; UFF geometry "
        "(15/2411, 82, 2412, 18/2420), modes (55) and spectra (58 types 2-9) too")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("files", nargs="+", type=Path, metavar="FILE", help=".uff/.unv, .csv or .json (SEP005)")
    parser.add_argument("--out", type=Path, required=True, metavar="DIR", help="new trace folder (DIR/traces/*.h5)")
    parser.add_argument("--map", type=Path, metavar="MAP.toml", help="sensor map: what the files lack")
    parser.add_argument("--name", help="campaign name (default: the map's, else the folder's name)")


def run(args: argparse.Namespace) -> int:
    overrides: list[str] = []
    written = api.import_data(args.files, args.out, args.map, args.name, overrides.append)
    for line in overrides:
        print(f"sensor map override: {line}")
    traces = [p for p in written if p.parent.name == "traces"]
    if traces:
        print(f"{len(traces)} trace file(s) in {args.out / 'traces'}")
    kinds = {"results": "modal results", "frf": "FRFs"}
    for path in written:
        if path.parent.name != "traces":
            print(f"{kinds.get(path.parent.name, 'geometry')}: {path}")
    return 0
