"""Identification from an FMU structbench did not build (issue 22): the 1-DOF
mass-spring-damper of tests/foreign_fmu (m = 1 kg, k = 1e4 N/m, d = 10 N s/m:
omega = 100 rad/s, zeta = 0.05; co-simulation by explicit Euler at the step,
and model exchange), through structbench.api.

Per case and seed: a campaign of 5 repetitions with 2 % sensor noise on the
force and the position (rms mode, a new noise realisation per repetition),
run, then ``modal`` (omega and zeta from the single position sensor) and
``least-squares`` (m, c, k with the model tests/foreign_fmu/msd.toml, from
force and position only). Cases:

- ``impulse-me``: a 1 N s pulse, 4 s at dt = 1 ms, model exchange (CVode, rtol 1e-10);
- ``random-sub``: a random force (1-3000 rad/s, nearly white up to pi / dt,
  1 N rms), 120 s at dt = 1 ms, co-simulation with ``substeps`` (default 100:
  Euler at h = 10 us still lowers zeta by omega h / 2 = 0.0005, 1 %; model
  exchange would take about a minute per record); output-only ``modal``
  needs the force white (at 5-500 rad/s it takes the band edges for modes);

each as exported (the position output ``y`` carries a 1 mm static offset)
and with ``[parameters] y0 = 0`` (the offset set to zero in the FMU).

Printed per case and quantity, over every (seed, repetition): the median
error and its spread (10th-90th percentile), signed, in % of the true value;
the 95 % interval coverage of least squares (share of (run, parameter)
pairs whose interval holds the truth) per seed: median and range.

    python benchmarks/foreign_fmu.py --seeds 5        # about 4-7 minutes on 2 cores

Measured (5 seeds x 5 repetitions; median [p10, p90], %; least squares
estimates the 1 mm offset, identifier/least_squares/offsets.py, commit 202d97e):

    impulse-me       modal omega +0.0015 [-0.012, +0.010], zeta +0.04 [-0.07, +0.25];
                     m -0.056 [-0.26, +0.14], c +0.09 [-0.60, +0.81], k -0.068 [-0.28, +0.17];
                     offset 1.000 mm [0.999, 1.000]; coverage 0.87 [0.60, 1.00]
                     (before the offsets were estimated: m -91.6, c +13.7, k -92.2, coverage 0)
    impulse-me-y0=0  modal omega -0.0005 [-0.007, +0.005], zeta +0.03 [-0.08, +0.14];
                     m -0.05 [-0.20, +0.14], c +0.10 [-0.59, +0.75], k -0.03 [-0.26, +0.17];
                     coverage 0.87 [0.67, 1.00] (no offset found: as before)
    random-sub       modal found 22/25, omega -0.18 [-0.48, +0.08], zeta -11.9 [-18, -5];
                     m -0.014 [-0.28, +0.44], c -1.07 [-1.49, -0.76], k -0.05 [-0.30, +0.45]
                     (the noise, 2 % of the RMS with the offset, is 10 times that of y0 = 0);
                     offset 1.000 mm; coverage 0.60 [0.60, 0.67] (c never covered, as below;
                     before: m -99.3, c -2.1, k -100, coverage 0)
    random-sub-y0=0  modal omega +0.006 [-0.64, +0.40], zeta +3.1 [-14, +10];
                     m +0.017 [-0.04, +0.05], c -1.01 [-1.14, -0.92] (Euler at 100 substeps:
                     c - m omega^2 h = -1 %, beyond its standard error), k +0.019 [-0.04, +0.05];
                     coverage 0.67 [0.60, 0.67] (c never covered)

    (offset: the least-squares estimate per run and record, mm)
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

import structbench.api as sb  # noqa: E402
from foreign_fixtures import D, K, M, OMEGA, ZETA, build_msd  # noqa: E402

MODEL = ROOT / "tests" / "foreign_fmu" / "msd.toml"
TRUE = {"mass[1]": M, "damping[3]": D, "stiffness[2]": K}
CAMPAIGN = """\
name = "msd-{case}"
structure = "{fmu}"
seed = {seed}
{interface}
[parameters]
{offset}
[mapping]
force = "f"
displacement = "y"

[locations]
1 = [0.0, 0.0, 0.0]

[[tests]]
name = "{kind}"
dt = 0.001
duration = {duration}
repetitions = 5
noise = {{sensor = {{displacement = 0.02, force = 0.02}}}}
excitation = [{excitation}]
sensors = [{{nodes = [1], dirs = ["x"], quantities = ["displacement", "force"]}}]
"""
EXCITATION = {"impulse": '{kind = "impulse", node = 1, dir = "x", impulse = 1.0}',
              "random": '{kind = "random", node = 1, dir = "x", rms = 1.0, band = [1.0, 3000.0]}'}


def campaign_text(case: str, fmu: Path, seed: int, substeps: int) -> str:
    kind = case.split("-")[0]
    interface = 'interface = "model-exchange"' if "-me" in case else f"substeps = {substeps}"
    return CAMPAIGN.format(case=case, fmu=fmu, seed=seed, interface=interface,
                           offset="y0 = 0.0" if case.endswith("y0=0") else "",
                           kind=kind, duration=4.0 if kind == "impulse" else 120.0, excitation=EXCITATION[kind])


def one(case: str, fmu: Path, seed: int, substeps: int, work: Path) -> dict[str, list[float]]:
    """Errors (%, signed) per quantity over the repetitions of one seed, and the coverage."""
    path = work / f"{case}-{seed}.toml"
    path.write_text(campaign_text(case, fmu, seed, substeps))
    out = work / f"{case}-{seed}"
    status = sb.run_campaign(path, out, jobs=1, check_step="auto" if seed == 0 else "off")  # the check once per case
    if status.failed:
        raise SystemExit(f"{case} seed {seed}: {[t.error for t in status.tests.values()]}")
    for warning in status.warnings:
        print(f"  {case}: {warning['message']}")
    errors: dict[str, list[float]] = {"omega": [], "zeta": [], "mass[1]": [], "damping[3]": [], "stiffness[2]": []}
    errors["modal missed"] = [0.0]
    for run in sb.identify(out, "modal", jobs=1)["runs"]:
        near = [j for j, w in enumerate(run["omega"]) if abs(w / OMEGA - 1) < 0.1]
        if not near:  # no mode reported within 10 %: counted, left out of the errors
            errors["modal missed"][0] += 1
            continue
        j = min(near, key=lambda j: abs(run["omega"][j] - OMEGA))
        errors["omega"].append(100 * (run["omega"][j] / OMEGA - 1))
        errors["zeta"].append(100 * (run["damping"][j] / ZETA - 1))
    inside = []
    for run in sb.identify(out, "least-squares", model=str(MODEL), jobs=1)["runs"]:
        for p in run["parameters"]:
            truth = TRUE[p["label"]]
            errors[p["label"]].append(100 * (p["value"] / truth - 1))
            inside.append(abs(p["value"] - truth) <= 1.96 * p["std_error"])
        errors.setdefault("offset (mm)", []).extend(1e3 * v for o in run["details"].get("offsets", {}).values()
                                                   for v in o.values())
    errors["coverage"] = [float(np.mean(inside))]
    return errors


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5, help="campaign seeds per case (each: 5 repetitions)")
    parser.add_argument("--substeps", type=int, default=100, help="doSteps per sample of the random cases")
    parser.add_argument("--cases", nargs="*", default=["impulse-me", "impulse-me-y0=0", "random-sub",
                                                        "random-sub-y0=0"])
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        fmu = build_msd(work)
        print(f"1-DOF FMU: m = {M} kg, k = {K:g} N/m, d = {D} N s/m (omega {OMEGA:g} rad/s, zeta {ZETA:g}); "
              f"{args.seeds} seeds x 5 repetitions, 2 % noise on force and position")
        print("errors in % of the true value: median [10th, 90th percentile] over every run; "
              "coverage: median [min, max] over seeds")
        for case in args.cases:
            start = time.monotonic()
            pooled: dict[str, list[float]] = {}
            for seed in range(args.seeds):
                for key, values in one(case, fmu, seed, args.substeps, work).items():
                    pooled.setdefault(key, []).extend(values)
            cells = [f"modal found the mode in {5 * args.seeds - int(sum(pooled.pop('modal missed')))}/"
                     f"{5 * args.seeds} runs"]
            for key, values in pooled.items():
                if not values:  # no offsets estimated
                    continue
                v = np.asarray(values)
                lo, mid, hi = (np.percentile(v, [10, 50, 90]) if key != "coverage" else (v.min(), np.median(v), v.max()))
                cells.append(f"{key} {mid:+.3g} [{lo:+.3g}, {hi:+.3g}]" if key != "coverage"
                             else f"coverage {mid:.2f} [{lo:.2f}, {hi:.2f}]")
            print(f"{case:16s} ({time.monotonic() - start:.0f} s): " + "; ".join(cells), flush=True)


if __name__ == "__main__":
    main()
