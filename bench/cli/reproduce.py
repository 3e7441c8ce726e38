"""``structbench reproduce``: the dissertation end to end, the main job."""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from structbench import api

from .progress import bar, interactive

HELP = "run every dissertation case through FMUs, harness, traces, identifiers and scoring; print and report"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", type=Path, default=Path("out/reproduce"),
                        help="output folder (default out/reproduce); a second run resumes (complete cases are "
                             "only scored again)")
    parser.add_argument("--repetitions", type=int, default=20,
                        help="Monte Carlo repetitions of the noisy tests (default 20; the damped beam's 8 h "
                             "ambient records: at most its campaign's 4)")
    parser.add_argument("--jobs", type=int, help="processes (default: one per CPU): two cases at a time, each "
                                                 "with half of them; 0 or 1: one case after the other")
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")
    parser.add_argument("--keep-traces", action="store_true",
                        help="keep every case's trace files (about 0.54 GB); by default they are deleted once "
                             "the case is identified and scored (its results, truth and the report stay)")


def _stderr(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def run(args: argparse.Namespace) -> int:
    start = time.perf_counter()
    shown = bar(None, "stage", "reproduce") if interactive() else None

    def stage(line: str) -> None:
        shown.set_description_str(line.strip()[:60])
        shown.update(1)

    try:
        summary = api.reproduce(args.out, args.repetitions, args.jobs, _stderr if shown is None else stage,
                                args.keep_traces)
    finally:
        if shown is not None:
            shown.close()
    if args.json:
        print(json.dumps(summary, indent=1))
    else:
        rows = api.reproduce_table(summary)
        width = max(len(r[0]) for r in rows)
        print(f"{'case':{width}s} | dissertation | this run")
        for case, published, ours in rows:
            print(f"{case:{width}s} | {published} | {ours}")
    _stderr(f"report: {args.out / 'report.md'} ({time.perf_counter() - start:.0f} s)")
    return 0
