"""``structbench run``: run a test campaign and log its traces.

Exit status: 0 when every test is done, 1 when some failed (they are named
in the summary; running again retries only them), 2 for user errors found
before any simulation, like the other commands, with the message on stderr.
Step-check warnings (external FMUs) are printed before the tests and in the
summary. ``--check-step`` runs only that check: exit 1 on a warning.
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

from structbench import api

from .progress import bar, interactive

HELP = "run a test campaign (TOML) on an FMU and log the sensors' traces (HDF5) into a folder"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("campaign", type=Path, metavar="CAMPAIGN.toml", help="campaign file")
    parser.add_argument("--out", type=Path, default=None, metavar="DIR",
                        help="output folder (required unless --check-step); run again to resume a killed campaign")
    parser.add_argument("--jobs", type=int, default=None, metavar="N",
                        help="local worker processes (default: one per CPU; 0: in this process)")
    parser.add_argument("--scheduler", default=None, metavar="ADDRESS",
                        help="run the tests on an existing Dask cluster, e.g. tcp://host:8786")
    parser.add_argument("--fmu-dir", type=Path, default=None, metavar="DIR",
                        help="where a built-in structure's FMU is built (default: DIR/fmus)")
    parser.add_argument("--check-step", action="store_true",
                        help="only check that the FMU's solver converged at the campaign's step (the first "
                             "test at its step and at half of it); exit 1 on a warning; writes no trace")


class Progress:
    """After every finished task: a bar over the trace files on a terminal,
    else one line per test that settled."""

    def __init__(self) -> None:
        self.bar = bar(None, "trace") if interactive() else None
        self.reported: set[str] = set()
        self.warned = False

    def __call__(self, status: api.CampaignStatus) -> None:
        tests = status.tests.values()
        if not self.warned and status.warnings:  # the step check, once, before the tests' progress
            self.warned = True
            print("\n".join(f"  WARNING {w['message']}" for w in status.warnings), flush=True)
        if self.bar is not None:
            self.bar.total = sum(len(t.traces) for t in tests)
            self.bar.n = sum(len(t.traces) if t.state == "failed" else len(t.present) for t in tests)
            self.bar.set_postfix_str(f"{status.count('done') + status.failed}/{len(status.tests)} tests"
                                     + (f", {status.failed} failed" if status.failed else ""), refresh=True)
            return
        for t in tests:
            if t.state in ("done", "failed") and t.name not in self.reported:
                self.reported.add(t.name)
                print(f"  {t.name}: {t.state} ({len(self.reported)}/{len(status.tests)} tests)", flush=True)

    def finish(self) -> None:
        if self.bar is not None:
            self.bar.close()


def summary(status: api.CampaignStatus, out: Path, seconds: float) -> str:
    """The lines printed at the end of a run."""
    total = len(status.tests)
    traces = sum(len(t.present) for t in status.tests.values())
    lines = [f"{status.campaign}: {status.count('done')}/{total} tests done "
             f"({status.skipped} already complete), {status.failed} failed, {traces} trace files in "
             f"{out / 'traces'} ({seconds:.1f} s)"]
    lines += [f"  FAILED {t.name}: {t.error}" for t in status.tests.values() if t.state == "failed"]
    lines += [f"  WARNING {w['message']}" for w in status.warnings]
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    if args.jobs is not None and args.jobs < 0:
        raise api.UserError("must be 0 or more", field="--jobs")
    if args.out is None and not args.check_step:
        raise api.UserError("required (unless --check-step)", field="--out")
    if args.out is not None and args.out.exists() and not args.out.is_dir():
        raise api.UserError("is a file, expected a folder", field="--out")
    campaign = api.load_campaign(args.campaign)
    if args.check_step:
        status = api.run_campaign(campaign, args.out, args.jobs, args.scheduler, args.fmu_dir, check_step="only")
        lines = [f"  WARNING {w['message']}" for w in status.warnings]
        print("\n".join(lines) if lines else f"{campaign.name}: step check passed (test "
              f"{next(iter(status.tests))}: the responses at the step and at half of it agree)")
        return 1 if status.warnings else 0
    print(f"{campaign.name}: {campaign.size}", flush=True)  # what the run is about to write and simulate
    progress = Progress()
    start = time.monotonic()
    try:
        status = api.run_campaign(campaign, args.out, args.jobs, args.scheduler, args.fmu_dir, progress)
    finally:
        progress.finish()
    print(summary(status, args.out, time.monotonic() - start))
    return 1 if status.failed else 0
