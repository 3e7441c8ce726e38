"""``structbench reproduce``: the dissertation end to end, the main job."""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from .report import table_rows, write_report
from .reproduce import run_all, stderr, summarize

HELP = "run every dissertation case through FMUs, harness, traces, identifiers and scoring; print and report"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", type=Path, default=Path("out/reproduce"),
                        help="output folder (default out/reproduce); a second run resumes")
    parser.add_argument("--repetitions", type=int, default=20,
                        help="Monte Carlo repetitions of the noisy tests (default 20)")
    parser.add_argument("--jobs", type=int, help="worker processes (default: one per CPU)")
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")


def run(args: argparse.Namespace) -> int:
    start = time.perf_counter()
    args.out.mkdir(parents=True, exist_ok=True)
    scores = run_all(args.out, args.repetitions, args.jobs, stderr)
    summary = summarize(scores)
    (args.out / "summary.json").write_text(json.dumps(summary, indent=1) + "\n")
    report = write_report(args.out, summary, scores)
    if args.json:
        print(json.dumps(summary, indent=1))
    else:
        rows = table_rows(summary)
        width = max(len(r[0]) for r in rows)
        print(f"{'case':{width}s} | dissertation | this run")
        for case, published, ours in rows:
            print(f"{case:{width}s} | {published} | {ours}")
    stderr(f"report: {report} ({time.perf_counter() - start:.0f} s)")
    return 0
