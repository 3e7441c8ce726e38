"""``structbench modes``: natural frequencies of a structure."""
from __future__ import annotations

import argparse
import json
from typing import Any

from structbench import api

HELP = "print natural frequencies (rad/s) of built-in structures or a TOML model"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("structures", nargs="*", metavar="NAME_OR_TOML",
                        help="built-in name or TOML model file (default: the dissertation's five)")
    parser.add_argument("--count", type=int, default=10, help="number of modes (default 10)")
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")


def header(res: dict[str, Any]) -> str:
    """What the model is (a modal model has its own number of modes, not
    one per DOF) and which of its modes follow."""
    if res["kind"] == "modal":
        what = f"modal model, {res['n_modes']} modes; forces and sensors at {res['n_dof']} DOF"
    else:
        what = f"finite-element model, {res['n_dof']} DOF, {res['n_modes']} modes"
    return f"{res['structure']} ({what}): modes 1-{len(res['omega'])}, natural frequencies omega (rad/s)"


def run(args: argparse.Namespace) -> int:
    results = [api.modes(name, args.count) for name in args.structures or api.DISSERTATION]
    if args.json:
        print(json.dumps(results[0] if len(results) == 1 else results, indent=2))
        return 0
    for res in results:
        print(header(res))
        for i, (w, lam) in enumerate(zip(res["omega"], res["lambda"]), start=1):
            print(f"  mode {i:2d}  omega = {w:10.6f}   omega^2 = {lam:10.6f} rad^2/s^2")
    return 0
