"""Campaign throughput: the chapter 3 campaign with 200 sensor-noise
repetitions (one simulation, 200 noisy traces of 97 channels x 4001 samples)
and a 24-test stepped sine on the chapter 4 cantilever (each test its own
simulation of 200 000 communication steps), each run with 1 and 2 local
workers. Prints wall time, tests (trace files) per second, the speed-up and
the machine's 1-minute load average before the run (on a shared machine,
other load takes cores from the workers).

    python benchmarks/campaign_throughput.py [--workers 1 2] [--only ch3|stepped]
"""
from __future__ import annotations

import argparse
import os
import re
import tempfile
import time
from pathlib import Path

import numpy as np

from structbench.harness.campaign import load_campaign
from structbench import run_campaign
from structbench.harness.fmu_setup import prepare_fmu

ROOT = Path(__file__).resolve().parent.parent
OMEGAS = ", ".join(f"{w:g}" for w in np.arange(1, 25) * 0.25)

STEPPED = f"""\
name = "stepped-sine-24"
structure = "ch4-cantilever-case1"
seed = 1

[[tests]]
name = "sweep"
dt = 0.05
step = 0.01
sensors = [{{nodes = "all", quantities = ["displacement"]}}]
noise = {{sensor = 0.01}}

[[tests.excitation]]
kind = "stepped-sine"
node = 7
dir = "w"
amplitude = 1.0
omegas = [{OMEGAS}]
ramp = 1000.0
window = 1000.0
"""


def campaigns(folder: Path, only: str | None = None) -> dict[str, Path]:
    """The benchmark campaigns (those whose label starts with ``only``) as files in ``folder``."""
    ch3 = re.sub(r"repetitions = \d+", "repetitions = 200", (ROOT / "campaigns" / "ch3.toml").read_text())
    files = {"ch3, 200 sensor-noise repetitions": ch3, "stepped sine, 24 tests": STEPPED}
    files = {label: text for label, text in files.items() if only is None or label.startswith(only)}
    out = {}
    for i, (label, text) in enumerate(files.items()):
        out[label] = folder / f"campaign{i}.toml"
        out[label].write_text(text)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--only", choices=["ch3", "stepped"], help="run one of the two campaigns")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="sb_bench_") as tmp:
        folder = Path(tmp)
        fmus = folder / "fmus"
        print(f"{'campaign':36s} {'workers':>7s} {'traces':>7s} {'wall (s)':>9s} {'traces/s':>9s} "
              f"{'speed-up':>9s} {'load':>6s}")
        for label, path in campaigns(folder, args.only).items():
            campaign = load_campaign(path)
            prepare_fmu(campaign, fmus)  # built once, outside the timing
            base = None
            for workers in args.workers:
                out = folder / f"{path.stem}-{workers}"
                load = os.getloadavg()[0]
                start = time.perf_counter()
                status = run_campaign(campaign, out, jobs=workers, fmu_dir=fmus)
                wall = time.perf_counter() - start
                traces = sum(len(t.present) for t in status.tests.values())
                base = base or wall
                print(f"{label:36s} {workers:7d} {traces:7d} {wall:9.2f} {traces / wall:9.2f} {base / wall:9.2f} {load:6.2f}",
                      flush=True)


if __name__ == "__main__":
    main()
