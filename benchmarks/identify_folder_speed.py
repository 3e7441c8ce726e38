"""Least squares through the product path: ``structbench identify`` of a
campaign folder with 100 repetitions of the chapter 3 harmonic test (32-DOF
beam, 97 channels x 4,001 samples per trace; the default estimator,
bias-compensated over every sample). Issue 11's target: under 10 s on 2 cores.

The folder is built once through the FMU (``campaigns/ch3.toml``, its
harmonic test) and kept in the temp dir. Measured in one run:

1. the whole command (``structbench identify`` in a fresh interpreter: start
   and imports included) with ``--jobs 1`` and ``--jobs 2``, interleaved,
   ``--repeat`` times each: wall time (min and median: other load on a
   shared machine only adds), CPU time of all its processes, peak resident
   memory of the main process and of the largest worker;
2. in this process, the split of ``--jobs 1``: reading the 100 traces
   (:func:`read_traces`) and identifying the 100 runs from memory;
3. whether the two results files hold the same numbers.

    python benchmarks/identify_folder_speed.py [--repetitions N] [--folder DIR] [--repeat K]
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from threadpoolctl import threadpool_limits

from structbench import run_campaign
from structbench.harness.campaign import load_campaign
from structbench.dispatch.methods import method
from structbench.identifier.io.traces import read_traces
from structbench.models import load_model

ROOT = Path(__file__).resolve().parent.parent
MEASURE = """\
import json, resource, sys, time
start = time.perf_counter()
from structbench.cli import main
code = main(sys.argv[1:])
me, workers = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
print(json.dumps({"code": code, "seconds": time.perf_counter() - start,
                  "cpu": me.ru_utime + me.ru_stime + workers.ru_utime + workers.ru_stime,
                  "main_mb": me.ru_maxrss / 1024, "worker_mb": workers.ru_maxrss / 1024}))
"""


def build(folder: Path, repetitions: int) -> Path:
    """The ch3 harmonic test with ``repetitions`` repetitions in ``folder`` (a finished folder is kept)."""
    campaign = load_campaign(ROOT / "campaigns" / "ch3.toml")
    test = dataclasses.replace(next(t for t in campaign.tests if t.name == "harmonic"), repetitions=repetitions)
    start = time.perf_counter()
    status = run_campaign(dataclasses.replace(campaign, tests=(test,)), folder)
    if status.failed:
        raise SystemExit(f"building {folder} failed: see {folder / 'status.json'}")
    print(f"folder {folder}: {len(list((folder / 'traces').glob('*.h5')))} traces "
          f"({time.perf_counter() - start:.1f} s to build or check)")
    return folder


def command(folder: Path, jobs: int) -> dict:
    """``structbench identify`` in a fresh interpreter: wall time (s) and peak memory (MB)."""
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", MEASURE, "identify", str(folder), "--method", "least-squares",
                           "--jobs", str(jobs), "--tag", f"speed-j{jobs}"], capture_output=True, text=True)
    wall = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(done.stderr)
    return json.loads(done.stdout.strip().splitlines()[-1]) | {"wall": wall}


def split(folder: Path) -> dict[str, tuple[float, float]]:
    """(wall, CPU) seconds to read every trace and to identify every run from
    memory, in this process with BLAS on 1 thread as the command runs it."""
    clock = (lambda: (time.perf_counter(), time.process_time()))
    start = clock()
    traces = read_traces(folder)
    read = clock()
    model, chosen = load_model(traces[0].structure), method("least-squares")
    settings = chosen.options({})
    with threadpool_limits(1, "blas"):
        for trace in traces:
            chosen.call([trace], model, **settings)
    end = clock()
    return {"read": (read[0] - start[0], read[1] - start[1]), "identify": (end[0] - read[0], end[1] - read[1])}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repetitions", type=int, default=100)
    parser.add_argument("--folder", type=Path, help="campaign folder (default: in the temp dir)")
    parser.add_argument("--repeat", type=int, default=3, help="timings of each command (default 3)")
    args = parser.parse_args()
    folder = build(args.folder or Path(tempfile.gettempdir()) / f"structbench-ch3-{args.repetitions}",
                   args.repetitions)
    print(f"load average before: {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores (other busy processes "
          "take cores from the workers: compare CPU times and ratios)")
    timed: dict[int, list[dict]] = {1: [], 2: []}
    for _ in range(args.repeat):  # interleaved: a burst of other load hits both alike
        for jobs, found in timed.items():
            found.append(command(folder, jobs))
    wall = {jobs: [r["wall"] for r in found] for jobs, found in timed.items()}
    for jobs, found in timed.items():
        print(f"structbench identify --jobs {jobs}: wall min {min(wall[jobs]):.2f} s, median "
              f"{statistics.median(wall[jobs]):.2f} s of {args.repeat} (interpreter start and imports included); "
              f"CPU median {statistics.median(r['cpu'] for r in found):.2f} s in all processes; peak RSS main "
              f"{max(r['main_mb'] for r in found):.0f} MB"
              + (f", largest worker {max(r['worker_mb'] for r in found):.0f} MB" if jobs > 1 else ""))
    print(f"speed-up jobs 2 / jobs 1 (medians): {statistics.median(wall[1]) / statistics.median(wall[2]):.2f}")
    parts = split(folder)
    print("split in one process: " + ", ".join(
        f"{name} {wall:.2f} s wall, {cpu:.2f} s CPU ({1e3 * cpu / args.repetitions:.1f} ms per run)"
        for name, (wall, cpu) in parts.items()))
    documents = [json.loads((folder / "results" / f"least-squares-speed-j{j}.json").read_text()) for j in (1, 2)]
    same = [d["runs"] for d in documents[:1]] == [d["runs"] for d in documents[1:]]
    print(f"results of --jobs 1 and --jobs 2 {'identical' if same else 'DIFFER'}; "
          f"load average after: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
