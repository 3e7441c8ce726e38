"""``structbench build-fmus``: package structures as FMI 2.0 co-simulation FMUs."""
from __future__ import annotations

import argparse
from pathlib import Path

from models import DISSERTATION, load_model
from models.errors import UserError
from models.fmu.builder import build_fmu, built_module, fmu_filename

HELP = "build FMUs of built-in structures or TOML models (skips FMUs that are up to date)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("structures", nargs="*", metavar="NAME_OR_TOML",
                        help="built-in name or TOML model file (default: the dissertation's five)")
    parser.add_argument("--out", type=Path, default=Path("fmus"), help="output folder (default fmus/)")


def run(args: argparse.Namespace) -> int:
    if args.out.exists() and not args.out.is_dir():
        raise UserError("is a file, expected a folder", field="--out")
    models = [load_model(name) for name in args.structures or DISSERTATION]
    for model in models:
        target = args.out / fmu_filename(model.name)
        before = built_module(target) if target.exists() else None
        path = build_fmu(model, args.out)
        state = "up to date" if built_module(path) == before else "built"
        print(f"{path}  {state}  ({model.n_dof} DOF)")
    return 0
