"""20 kill -9 / resume cycles of a parallel campaign (2 workers), each
killed at a random moment (seeded; uniform between the first trace and the
end of an uninterrupted run), with a booked trace file damaged
between kill and resume in every other cycle; reports per cycle whether the
final traces are bit-identical to an uninterrupted run.

    python benchmarks/kill_resume.py [--cycles 20] [--seed 13]
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from kill_cycles import kill_cycle, prepare  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=20)
    parser.add_argument("--seed", type=int, default=13)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    with tempfile.TemporaryDirectory() as tmp:
        bench = prepare(Path(tmp))
        print(f"uninterrupted run: {bench.seconds:.1f} s, first trace after {bench.first:.1f} s; "
              "kills drawn between the two")
        identical = 0
        for i in range(args.cycles):
            cycle = kill_cycle(bench, Path(tmp) / f"cycle{i}", rng, damage=i % 2 == 0)
            identical += cycle.identical and cycle.resumed_code == 0
            print(f"cycle {i + 1:2d}: killed after {cycle.killed_after:5.2f} s with {cycle.traces_at_kill:3d} "
                  f"traces written; damaged {cycle.damaged or '-':14s} resume exit {cycle.resumed_code}; "
                  f"{'identical' if cycle.identical else 'DIFFERENT'}", flush=True)
    print(f"{identical}/{args.cycles} cycles identical to the uninterrupted run")
    return 0 if identical == args.cycles else 1


if __name__ == "__main__":
    sys.exit(main())
