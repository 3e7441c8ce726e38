"""Predicted standard errors (``structbench plan``) against Monte Carlo through
the FMU and the identifier (``--verify N``).

Cases:

1. least squares, chapter 3 beam (``campaigns/ch3.toml``, test ``harmonic``:
   30 parameters, 2 % noise on accelerations and force);
2. least squares, a structure not in the repository (``plan_models.frame``:
   a 4-storey shear frame with a tuned-mass appendage, 10 parameters, a
   shared random force at floor 2, 2 % noise on accelerations and force);
3. modal omega and zeta, a free decay (``campaigns/ch5-damped.toml``, test
   ``impulse``: 1 N s impulse, 1000 s, 2 % noise): the modal method as it
   runs (SSI-cov, its poles refined by maximum likelihood on free decays,
   identifier/modal/refine.py), and the same runs identified again with
   ``refine=off`` (SSI-cov alone) for comparison.

Per quantity the ratio achieved / predicted standard deviation (the
sample standard deviation of N runs has a relative standard error of
``1 / sqrt(2 (N - 1))``, 5 % at N = 200). Target: the median over quantities
within 20 % of 1. Prints the figures.

    python benchmarks/plan_accuracy.py [--reps 200] [--case ch3|frame|modal]
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
import plan_models  # noqa: E402

import structbench as sb  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
FRAME = """name = "plan-frame"
structure = "{model}"
seed = 17
[[tests]]
name = "shaker"
dt = 0.005
duration = 20.0
noise = {{sensor = {{acceleration = 0.02, force = 0.02}}}}
[[tests.excitation]]
kind = "random"
node = 2
dir = "x"
rms = 5.0
band = [0.0, 60.0]
seed = 3
[[tests.sensors]]
nodes = "all"
quantities = ["acceleration", "velocity", "displacement"]
[[tests.sensors]]
nodes = [2]
dirs = ["x"]
quantities = ["force"]
"""


def summary(name: str, doc: dict, seconds: float, ver: dict | None = None) -> None:
    ver = ver or doc["verify"]
    rows = ver["parameters"] or [{"label": f"mode {i + 1} {q}", "ratio": m[f"{q}_ratio"]}
                                 for i, m in enumerate(ver["modes"]) for q in ("omega", "zeta")]
    ratios = np.array([r["ratio"] for r in rows if r["ratio"] is not None])
    med = float(np.median(ratios))
    print(f"\n== {name}: {ver['runs']} Monte Carlo runs, {seconds:.0f} s; {ratios.size} quantities")
    print(f"achieved / predicted std: median {med:.3f}, 10-90 % {np.percentile(ratios, 10):.3f}-"
          f"{np.percentile(ratios, 90):.3f}, min {ratios.min():.3f}, max {ratios.max():.3f}; "
          f"median |ratio - 1| {np.median(np.abs(ratios - 1)):.3f}; "
          f"target median within 20 %: {'met' if abs(med - 1) <= 0.2 else 'MISSED'}")
    if ver["modes"]:
        for i, m in enumerate(ver["modes"], start=1):
            print(f"  mode {i:2d} omega {m['omega']:8.4f}: found {m['runs']:3d}/{ver['runs']}, std omega "
                  f"{m['predicted_omega_std']:.2e} predicted, {m['achieved_omega_std'] or float('nan'):.2e} achieved; "
                  f"zeta {m['predicted_zeta_std']:.2e}, {m['achieved_zeta_std'] or float('nan'):.2e}")


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--reps", type=int, default=200)
    parser.add_argument("--case", choices=("ch3", "frame", "modal"), action="append")
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    cases = args.case or ["ch3", "frame", "modal"]
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        model = plan_models.frame(folder / "frame.toml")
        (folder / "frame-campaign.toml").write_text(FRAME.format(model=model.name))
        plans = {"ch3": ("least squares, chapter 3 beam", ROOT / "campaigns" / "ch3.toml", "least-squares", "harmonic"),
                 "frame": ("least squares, frame with appendage (not in the repository)",
                           folder / "frame-campaign.toml", "least-squares", "shaker"),
                 "modal": ("modal (SSI-cov + maximum-likelihood refinement), free decay of the damped chapter 5 beam",
                           ROOT / "campaigns" / "ch5-damped.toml", "modal", "impulse")}
        for case in cases:
            name, campaign, method, test = plans[case]
            start = time.perf_counter()
            doc = sb.plan(campaign, method, test=test, verify=args.reps, seed=1, jobs=args.jobs,
                          verify_out=folder / f"{case}-mc")
            summary(name, doc, time.perf_counter() - start)
            if method == "modal":  # the same runs, SSI-cov alone
                from structbench.planning.verify import compare
                start = time.perf_counter()
                off = sb.identify(folder / f"{case}-mc", method, groups=[test], jobs=args.jobs, refine="off",
                                  tag="refine-off")
                summary("the same runs with refine=off (SSI-cov alone)", doc, time.perf_counter() - start,
                        compare(doc, off["runs"]) | {"runs": len(off["runs"])})


if __name__ == "__main__":
    main()
