"""The long fuzz profile: the properties of tests/fuzz_cases.py with many
cases per format (default 1,000), counting cases, outcomes and tracebacks.

    python benchmarks/fuzz_long.py [--examples N] [--formats campaign,model,...] [--seed S]

A traceback is any exception escaping ``structbench.cli.main``; a violated
property (exit code, several error lines, leftovers) and a hang (a case over
HANG_SECONDS) are counted apart.
Prints one line per format and the distinct places tracebacks came from;
exits 1 if there was any traceback or violation.
"""
from __future__ import annotations

import argparse
import collections
import json
import signal
import sys
import tempfile
import time
import traceback
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from hypothesis import HealthCheck, given, seed as hypothesis_seed, settings, strategies as st  # noqa: E402

import fuzz_cases as cases  # noqa: E402
from fuzz_strategies import mappings, mutated_json, mutated_toml, trace_damage  # noqa: E402

FORMATS = ("campaign", "model", "trace", "results", "mapping")
JSON_TARGETS = ["results/least-squares.json", "results/rayleigh.json", "truth.json"]


HANG_SECONDS = 120  # a case running longer counts as a hang


class Hang(BaseException):
    """Raised by SIGALRM in a case that runs too long."""


def _alarm(signum: int, frame: object) -> None:
    raise Hang


class Tally:
    """Cases, exit codes, tracebacks (with the place they came from), property
    violations, hangs and the slowest case (s)."""

    def __init__(self) -> None:
        self.cases, self.tracebacks, self.violations, self.hangs, self.slowest = 0, 0, 0, 0, 0.0
        self.codes: collections.Counter[int] = collections.Counter()
        self.places: collections.Counter[str] = collections.Counter()

    def run(self, case, *args) -> None:
        self.cases += 1
        if self.cases % 100 == 0:
            print(f"  ... {self.cases} cases, slowest {self.slowest:.1f} s", file=sys.stderr, flush=True)
        signal.alarm(HANG_SECONDS)
        start = time.monotonic()
        try:
            self.codes[case(*args)] += 1
        except Hang:
            self.hangs += 1
            self.places[f"hang (> {HANG_SECONDS} s): {str(args)[:200]}"] += 1
        except AssertionError as err:
            self.violations += 1
            self.places[f"property: {str(err)[:160]}"] += 1
        except Exception as err:  # noqa: BLE001 - a traceback is what we count
            self.tracebacks += 1
            frame = traceback.extract_tb(err.__traceback__)[-1]
            self.places[f"{type(err).__name__} at {Path(frame.filename).name}:{frame.lineno}"] += 1
        finally:
            signal.alarm(0)
            self.slowest = max(self.slowest, time.monotonic() - start)


def strategy(fmt: str, seeds: dict[str, Path]):
    """The (strategy, case function) of one format."""
    if fmt == "campaign":
        texts = [cases.parsed(p) for p in cases.CAMPAIGNS]
        return (st.tuples(st.sampled_from(texts).flatmap(lambda c: mutated_toml(*c))),
                lambda text: cases.campaign_case(text, seeds["scratch"], seeds["fmus"]))
    if fmt == "model":
        texts = [cases.parsed(p) for p in cases.MODELS]
        return (st.tuples(st.sampled_from(texts).flatmap(lambda m: mutated_toml(*m))),
                lambda text: cases.model_case(text, seeds["scratch"]))
    if fmt == "trace":
        return (st.tuples(trace_damage(), st.integers(0, 3), st.sampled_from(["least-squares", "rayleigh"])),
                lambda d, w, m: cases.trace_case(d, w, m, seeds["trace"], seeds["scratch"]))
    if fmt == "results":
        docs = {t: json.loads((seeds["score"] / t).read_text()) for t in JSON_TARGETS}
        drawn = st.sampled_from(JSON_TARGETS).flatmap(lambda t: st.tuples(st.just(t), mutated_json(docs[t])))
        return (st.tuples(drawn, st.sampled_from(["score", "check"])),
                lambda tt, cmd: cases.results_case(tt[1], tt[0], cmd, seeds["score"], seeds["scratch"]))
    return (st.tuples(mappings()), lambda m: cases.mapping_case(m, seeds["external"], seeds["scratch"]))


def fuzz(fmt: str, examples: int, seeds: dict[str, Path], seed: int) -> Tally:
    tally = Tally()
    drawn, case = strategy(fmt, seeds)

    @settings(max_examples=examples, deadline=None, database=None, derandomize=False,
              suppress_health_check=list(HealthCheck))
    @given(args=drawn)
    def property_(args) -> None:
        tally.run(case, *args)

    hypothesis_seed(seed)(property_)()
    return tally


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--examples", type=int, default=1000, help="cases per format (default 1000)")
    parser.add_argument("--formats", default=",".join(FORMATS))
    parser.add_argument("--seed", type=int, default=2026)
    args = parser.parse_args()
    bad = 0
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        seeds = {name: root / name for name in ("scratch", "fmus", "trace", "score", "external")}
        for path in seeds.values():
            path.mkdir()
        cases.trace_seed(seeds["trace"]), cases.score_seed(seeds["score"]), cases.external_seed(seeds["external"])
        signal.signal(signal.SIGALRM, _alarm)
        print(f"{'format':10s} {'cases':>6s} {'tracebacks':>10s} {'violations':>10s} {'hangs':>5s} {'slowest':>8s}"
              "  exit codes")
        for fmt in args.formats.split(","):
            tally = fuzz(fmt, args.examples, seeds, args.seed)
            codes = ", ".join(f"{c}: {n}" for c, n in sorted(tally.codes.items()))
            print(f"{fmt:10s} {tally.cases:6d} {tally.tracebacks:10d} {tally.violations:10d} {tally.hangs:5d} "
                  f"{tally.slowest:7.1f}s  {codes}", flush=True)
            for place, n in tally.places.most_common(15):
                print(f"    {n:5d}  {place}")
            bad += tally.tracebacks + tally.violations + tally.hangs
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
