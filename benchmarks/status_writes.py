"""Cost of rewriting status.json: one sensor-noise test with many
repetitions of a tiny trace on the C test FMU (2 workers), run with
status.json rewritten after every task (STATUS_SECONDS = 0, as before) and
at most once a second (the default), alternately, twice each; prints the
wall-clock times and the ratio of the best of each.

    python benchmarks/status_writes.py [--repetitions 20000]
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

import structbench.harness.schedule as schedule  # noqa: E402
from structbench import run_campaign  # noqa: E402
from faulty_fixtures import build_faulty  # noqa: E402

CAMPAIGN = """\
name = "many"
structure = "{fmu}"

[mapping]
force = "F_{{node}}_{{dir}}"
displacement = "u_{{node}}_{{dir}}"

[locations]
1 = [0.0, 0.0, 0.0]

[[tests]]
name = "mc"
dt = 0.01
duration = 0.05
repetitions = {repetitions}
noise = {{sensor = 0.01}}
excitation = [{{kind = "harmonic", node = 1, dir = "z", amplitude = 1.0, omega = 5.0}}]
sensors = [{{nodes = [1], dirs = ["z"], quantities = ["displacement"]}}]
"""


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repetitions", type=int, default=20000)
    args = parser.parse_args()
    best: dict[float, float] = {}
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        path = root / "many.toml"
        path.write_text(CAMPAIGN.format(fmu=build_faulty(root), repetitions=args.repetitions))
        for i, seconds in enumerate((0.0, 1.0, 0.0, 1.0)):
            schedule.STATUS_SECONDS = seconds
            start = time.monotonic()
            status = run_campaign(path, root / f"out{i}", jobs=2)
            took = time.monotonic() - start
            assert status.failed == 0
            best[seconds] = min(best.get(seconds, took), took)
            print(f"{args.repetitions} traces, status.json at most every {seconds:g} s: {took:.1f} s", flush=True)
    print(f"every task / at most once a second (best of 2 each): {best[0.0] / best[1.0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
