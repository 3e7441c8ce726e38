"""``structbench traces``: what a campaign output folder holds."""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from structbench import api

HELP = "list the tests, trace files and channels of a campaign output folder"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("folder", type=Path, metavar="DIR", help="campaign output folder (structbench run --out)")
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")


def origin(data: dict) -> str:
    """The first line: the campaign that was run, or the lab files imported."""
    truth = f"truth.json {'present' if data['truth'] else 'absent'}"
    if data.get("imported"):
        files = data["sources"]
        shown = ", ".join(files[:3]) + (f" and {len(files) - 3} more" if len(files) > 3 else "")
        names = [f"{what} {data[what]}" for what in ("campaign", "structure") if data[what]]
        return (f"imported lab data (structbench import) from {len(files)} file(s): {shown}"
                + (f"; {', '.join(names)}" if names else "") + f"; {truth}")
    return (f"campaign {data['campaign'] or '?'} on {data['structure'] or '?'} "
            f"(FMU sha256 {data['fmu_sha256'][:12] or '?'}); {truth}")


def _table(data: dict) -> str:
    lines = [origin(data),
             f"{sum(t['files'] for t in data['tests'])} trace files, {data['bytes'] / 1e6:.1f} MB"
             + ("; " + ", ".join(f"{k} {v}" for k, v in data["summary"].items()) if data["summary"] else "")]
    head = f"{'test':24s} {'state':8s} {'files':>9s} {'dt (s)':>9s} {'samples':>8s} {'channels':>8s}  excitation"
    lines.append(head)
    state = "imported" if data.get("imported") else "?"
    for t in data["tests"]:
        files = f"{t['files']}/{t.get('expected', t['files'])}"
        omega = f" omega = {t['omega']:g} rad/s" if t.get("omega") is not None else ""
        sampling = (f"{t['dt']:9.4g} {t['samples']:8d} {len(t['channels']):8d}  {t['excitation']}{omega}"
                    if "dt" in t else "")
        lines.append(f"{t['test']:24s} {t.get('state', state):8s} {files:>9s} {sampling}")
        if t.get("error"):
            lines.append(f"    error: {t['error']}")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    data = api.list_traces(args.folder)
    print(json.dumps(data, indent=1) if args.json else _table(data))
    return 0
