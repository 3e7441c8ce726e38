"""``structbench plan``: predicted standard errors of a test before it is run,
sensor layouts, and their Monte Carlo check (docs/plan.md)."""
from __future__ import annotations

import argparse
import json
import sys

from structbench import api

HELP = ("predict the standard errors (Cramer-Rao bounds) a method will reach on a campaign's test; "
        "choose a sensor layout; --verify N checks them by Monte Carlo")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("campaign", metavar="CAMPAIGN.toml", help="the campaign (its structure is the planning model)")
    parser.add_argument("--method", required=True, help="least-squares or modal")
    parser.add_argument("--model", metavar="NAME_OR_TOML", help="planning model instead of the campaign's structure")
    parser.add_argument("--test", metavar="NAME", help="test group (default: the campaign's first)")
    parser.add_argument("--candidates", metavar="FILE", help="candidate sensors, TOML or CSV (docs/plan.md)")
    parser.add_argument("--sensors", type=int, metavar="K", help="sensor budget: channels to choose")
    parser.add_argument("--layout-out", metavar="FILE", help="campaign file of the chosen layout")
    parser.add_argument("--verify", type=int, default=0, metavar="N", help="Monte Carlo repetitions through the FMU")
    parser.add_argument("--seed", type=int, default=0, help="seed of the --verify runs (default 0)")
    parser.add_argument("--verify-out", metavar="DIR", help="keep the --verify campaign folder here")
    parser.add_argument("--jobs", type=int, help="processes for --verify (default one per core)")
    parser.add_argument("--json", action="store_true", help="print the plan document (JSON) instead of a table")


def run(args: argparse.Namespace) -> int:
    say = (lambda line: print(line, file=sys.stderr)) if not args.json else None
    doc = api.plan(args.campaign, args.method, model=args.model, test=args.test, candidates=args.candidates,
                   sensors=args.sensors, layout_out=args.layout_out, verify=args.verify, seed=args.seed,
                   verify_out=args.verify_out, jobs=args.jobs, progress=say)
    if args.json:
        print(json.dumps(doc, indent=1))
        return 0
    from structbench.planning.report import table
    print("\n".join(table(doc)))
    return 0
