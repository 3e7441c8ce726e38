"""``structbench plan``: predicted standard errors of a test before it is run,
sensor layouts, and their Monte Carlo check (docs/plan.md)."""
from __future__ import annotations

import argparse
import json
import sys

from typing import Any

from structbench import api

HELP = ("predict the standard errors (Cramer-Rao bounds) a method will reach on a campaign's test; "
        "choose a sensor layout; --verify N checks them by Monte Carlo")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("campaign", metavar="CAMPAIGN.toml", help="the campaign (its structure is the planning model)")
    parser.add_argument("--method", required=True, help="least-squares, modal or updating")
    parser.add_argument("--model", metavar="NAME_OR_TOML", help="planning model instead of the campaign's structure")
    parser.add_argument("--test", metavar="NAME", help="test group (default: the campaign's first)")
    parser.add_argument("--candidates", metavar="FILE", help="candidate sensors, TOML or CSV (docs/plan.md)")
    parser.add_argument("--sensors", type=int, metavar="K", help="sensor budget: channels to choose")
    parser.add_argument("--criterion", default="frequencies",
                        choices=("frequencies", "d-optimal", "effective-independence"),
                        help="layout criterion (default frequencies: least predicted RMS relative error of the "
                             "target modes' frequencies)")
    parser.add_argument("--target-modes", type=int, metavar="N",
                        help="the frequencies criterion targets the lowest N planned modes (default all)")
    parser.add_argument("--drives", metavar="FILE",
                        help="candidate excitation points of the test's impulse, TOML or CSV (docs/plan.md)")
    parser.add_argument("--layout-out", metavar="FILE", help="campaign file of the chosen layout or drive")
    parser.add_argument("--verify", type=int, default=0, metavar="N", help="Monte Carlo repetitions through the FMU")
    parser.add_argument("--seed", type=int, default=0, help="seed of the --verify runs (default 0)")
    parser.add_argument("--verify-out", metavar="DIR", help="keep the --verify campaign folder here")
    parser.add_argument("--jobs", type=int, help="processes for --verify (default one per core)")
    parser.add_argument("--json", action="store_true", help="print the plan document (JSON) instead of a table")


def run(args: argparse.Namespace) -> int:
    say = (lambda line: print(line, file=sys.stderr)) if not args.json else None
    doc = api.plan(args.campaign, args.method, model=args.model, test=args.test, candidates=args.candidates,
                   sensors=args.sensors, layout_out=args.layout_out,
                   criterion=args.criterion, target_modes=args.target_modes, drives=args.drives, verify=args.verify, seed=args.seed,
                   verify_out=args.verify_out, jobs=args.jobs, progress=say)
    if args.json:
        print(json.dumps(doc, indent=1))
        return 0
    print("\n".join(table(doc)))
    return 0


def _num(x: float | None, fmt: str = ".3g") -> str:
    return "-" if x is None else format(x, fmt)


def table(doc: dict[str, Any]) -> list[str]:
    """Lines: a header, one row per parameter or mode (value, predicted standard
    error and, after ``--verify``, the achieved one and their ratio), the layout."""
    lines = [f"plan: {doc['method']} on test {doc['test']!r} of campaign {doc['campaign']} "
             f"(planning model {doc['model']}); predicted standard errors (Cramer-Rao), SI units"]
    ver = doc.get("verify")
    if doc.get("layout"):
        lay = doc["layout"]
        lines.append(f"layout: {lay['chosen']} by criterion {lay['criterion']} ({len(lay['sensors'])} of "
                     f"{lay['candidates']} candidates; {len(lay['target_modes'])} target modes) -> "
                     f"{lay['campaign']}")
        for name, row in lay["layouts"].items():
            lines.append(f"  {name:22s} log det F = {row['log_det']:10.4g}   predicted omega std / omega: median "
                         f"{row['median_rel_omega_std']:.3g}, RMS of the targets {row['rms_rel_omega_std']:.3g}"
                         "   sensors: "
                         + " ".join(f"{q[0]}_{n}_{d}" for n, d, q in row["sensors"]))
    if doc.get("drives"):
        dr = doc["drives"]
        lines.append(f"excitation point: node {dr['chosen'][0]} {dr['chosen'][1]} ({dr['candidates']} candidates, "
                     f"{len(dr['sensors'])} sensors; {len(dr['target_modes'])} target modes) -> {dr['campaign']}")
        for row in dr["ranking"][:5]:
            lines.append(f"  node {row['node']:5d} {row['dir']:6s} RMS predicted omega std / omega of the targets "
                         f"{_num(row['rms_rel_omega_std'])}" + (f", {len(row['missed'])} target modes not seen"
                                                                if row["missed"] else ""))
    if doc["parameters"]:
        extra = "   achieved      ratio" if ver else ""
        lines.append(f"  {'parameter':16s} {'unit':6s} {'value':>11s} {'predicted std':>14s} {'rel':>9s}{extra}")
        rows = ver["parameters"] if ver else [None] * len(doc["parameters"])
        for p, v in zip(doc["parameters"], rows):
            line = (f"  {p['label']:16s} {p['unit']:6s} {p['value']:11.5g} {p['predicted_std']:14.4g} "
                    f"{p['predicted_std'] / abs(p['value']) if p['value'] else float('nan'):9.2e}")
            if v is not None:
                line += f" {_num(v['achieved_std'], '10.4g'):>10s} {_num(v['ratio'], '10.3f'):>10s}"
            lines.append(line)
    if doc["modes"]:
        extra = "  achieved(omega, zeta)  ratios" if ver else ""
        lines.append(f"  {'mode':>4s} {'omega rad/s':>12s} {'std':>10s} {'zeta':>8s} {'std':>10s}{extra}")
        rows = ver["modes"] if ver else [None] * len(doc["modes"])
        for i, (m, v) in enumerate(zip(doc["modes"], rows), start=1):
            line = (f"  {i:4d} {m['omega']:12.6g} {m['predicted_omega_std']:10.3g} {m['zeta']:8.4f} "
                    f"{m['predicted_zeta_std']:10.3g}")
            if v is not None:
                line += (f"  {_num(v['achieved_omega_std'])} {_num(v['achieved_zeta_std'])}  "
                         f"{_num(v['omega_ratio'], '.2f')} {_num(v['zeta_ratio'], '.2f')}")
            lines.append(line)
    if doc.get("not_visible"):
        lines.append("  not planned (too weak in this test): omega = "
                     + ", ".join(f"{w:.4g}" for w in doc["not_visible"]) + " rad/s")
    if ver:
        lines.append(f"verify: {ver['runs']} Monte Carlo runs (seed {ver['seed']}); median achieved / predicted = "
                     f"{_num(ver['median_ratio'], '.3f')}")
    return lines
