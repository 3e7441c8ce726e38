"""``structbench plot-modes``: each identified mode drawn on the test geometry.

A PNG per mode of ``DIR/results/*.json`` (modal schema, docs/results-format.md)
into ``DIR/modes/`` (undeformed geometry in grey, deformed in colour); with
``--animate`` also a GIF (Pillow) or an HTML page per mode. The geometry:
``--geometry FILE`` (docs/geometry-format.md), else ``DIR/geometry.json``
(written by ``structbench import``), else the results' model.
"""
from __future__ import annotations

import argparse
from pathlib import Path

from structbench import api

HELP = "draw each identified mode on the geometry: a PNG per mode, an animation with --animate"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("campaign_dir", type=Path, metavar="DIR", help="folder with results/*.json")
    parser.add_argument("--geometry", type=Path, metavar="FILE",
                        help="geometry JSON (default DIR/geometry.json, else the results' model)")
    parser.add_argument("--animate", choices=["gif", "html"], help="also one animation per mode")
    parser.add_argument("--out", type=Path, metavar="DIR2", help="folder for the plots (default DIR/modes)")
    parser.add_argument("--scale", type=float, default=0.1,
                        help="largest displacement as a fraction of the geometry's size (default 0.1)")
    parser.add_argument("--run", type=int, default=0, help="which run of each results file (default 0, the first)")


def run(args: argparse.Namespace) -> int:
    written = api.plot_modes(args.campaign_dir, args.geometry, args.animate, args.out, args.scale, args.run)
    for path in written:
        print(path)
    return 0
