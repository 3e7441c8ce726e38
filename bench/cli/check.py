"""``structbench check``: exit 1 when a threshold of the campaign's ``[check]`` table fails."""
from __future__ import annotations

import argparse
import time
from pathlib import Path

from structbench import api

HELP = "gate: exit 1 if the campaign's [check] thresholds are not met by its scores"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("campaign_dir", type=Path, metavar="CAMPAIGN_DIR")
    parser.add_argument("--junit-xml", type=Path, metavar="FILE",
                        help="also write the gates as a JUnit XML report (one test case per gate) for CI servers")


def run(args: argparse.Namespace) -> int:
    start = time.perf_counter()
    try:
        rows = api.check(args.campaign_dir)
    except api.UserError as err:  # the CI server's report says why there are no gates
        if args.junit_xml is not None:
            api.write_junit([], args.junit_xml, time.perf_counter() - start,
                            error=(args.campaign_dir.name, str(err)))
        raise
    if args.junit_xml is not None:
        api.write_junit(rows, args.junit_xml, time.perf_counter() - start)
    for r in rows:
        print(f"{'PASS' if r['ok'] else 'FAIL'}  {r['results']:36s} {r['gate']:22s} "
              f"{r['value']:.4g} (threshold {r['threshold']:g})")
    failed = [r for r in rows if not r["ok"]]
    print(f"{len(rows) - len(failed)} passed, {len(failed)} failed")
    return 1 if failed else 0
