"""``structbench modes``: natural frequencies of a structure."""
from __future__ import annotations

import argparse
import json

from models import DISSERTATION, load_model
from models.errors import UserError

HELP = "print natural frequencies (rad/s) of built-in structures or a TOML model"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("structures", nargs="*", metavar="NAME_OR_TOML",
                        help="built-in name or TOML model file (default: the dissertation's five)")
    parser.add_argument("--count", type=int, default=10, help="number of modes (default 10)")
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")


def frequencies(name: str, count: int) -> dict:
    model = load_model(name)
    m = model.modes(count)
    return {"structure": model.name, "n_dof": model.n_dof,
            "omega": [float(w) for w in m.omega], "lambda": [float(v) for v in m.lam]}


def run(args: argparse.Namespace) -> int:
    names = args.structures or DISSERTATION
    if args.count < 1:
        raise UserError("must be at least 1", field="--count")
    results = [frequencies(name, args.count) for name in names]
    if args.json:
        print(json.dumps(results[0] if len(results) == 1 else results, indent=2))
        return 0
    for res in results:
        print(f"{res['structure']} ({res['n_dof']} DOF): natural frequencies omega (rad/s)")
        for i, (w, lam) in enumerate(zip(res["omega"], res["lambda"]), start=1):
            print(f"  mode {i:2d}  omega = {w:10.6f}   omega^2 = {lam:10.6f} rad^2/s^2")
    return 0
