"""``structbench build-fmus``: package structures as FMI 2.0 co-simulation FMUs."""
from __future__ import annotations

import argparse
from pathlib import Path

from structbench import api

HELP = "build FMUs of built-in structures or TOML models (skips FMUs that are up to date)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("structures", nargs="*", metavar="NAME_OR_TOML",
                        help="built-in name or TOML model file (default: the dissertation's five)")
    parser.add_argument("--out", type=Path, default=None,
                        help="output folder (default $STRUCTBENCH_FMU_DIR or ~/.cache/structbench/fmus)")


def run(args: argparse.Namespace) -> int:
    for fmu in api.build_fmus(args.structures, args.out):
        print(f"{fmu.path}  {'built' if fmu.built else 'up to date'}  ({fmu.n_dof} DOF)")
    return 0
