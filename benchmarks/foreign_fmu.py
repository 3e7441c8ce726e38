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
  1 N rms; one realisation per seed, the same for its repetitions), 120 s at
  dt = 1 ms, co-simulation with ``substeps`` (default 1000: Euler at
  h = 1 us still lowers zeta and c by omega h / 2 = m omega^2 h / c =
  0.1 %; at 100 substeps by 1 %, which least squares resolved: c -1.0 %,
  never inside its interval. Model exchange did not finish one 120 s random
  record in the harness's 600 s at load 10); output-only ``modal`` needs
  the force white (at 5-500 rad/s it takes the band edges for modes);

each as exported (the position output ``y`` carries a 1 mm static offset)
and with ``[parameters] y0 = 0`` (the offset set to zero in the FMU).

Printed per case and quantity, over every (seed, repetition): the median
error and its spread (10th-90th percentile), signed, in % of the true value
(``omega``, ``zeta``: the SSI's, output-only; ``io omega``, ``io zeta``:
the pole-residue fit of the FRFs with the measured force, ``modal``'s
``details.input_output``); the 95 % interval coverage of least squares
(share of (run, parameter) pairs whose interval holds the truth) and of
the input-output poles (omega and zeta) per seed: median and range.
With a measured force, ``--option input=poles`` makes the ``io`` poles and
their standard errors ``modal``'s reported omega and zeta (commit 63c3efa;
the SSI's stay in ``details.ssi``): the issue's one-sensor target (omega
within 0.1 %, zeta within 5 %) is met by them in every case below, and
missed by output-only SSI's omega in the random cases.

    python benchmarks/foreign_fmu.py --seeds 5 [--first 200] [--no-check-step]

Developed on seeds 100-104 (and exact numpy simulations, seeds 0-17, for
identifier/modal/residues.py); the figures below on seeds 200-204, run once
(--no-check-step; commit 8213465 plus another helper's uncommitted
harmonics/stabilisation edits in the working tree, which touch only the
SSI columns; 2 processes at load about 10: random cases 1250-1280 s each,
impulse cases 40 s). Median [p10, p90] over 5 seeds x 5 repetitions, %:

    random-sub       modal (SSI) found 25/25, omega -0.23 [-1.23, +0.29], zeta -3.7 [-25, +5.7];
                     io omega +0.0057 [-0.0076, +0.022], io zeta -0.099 [-0.50, +0.17], io coverage 1.00 [0.90, 1.00];
                     m +0.055 [-0.29, +0.27], c -0.083 [-0.25, +0.28], k +0.055 [-0.25, +0.26];
                     offset 1.000 mm; coverage 1.00 [1.00, 1.00] (the noise, 2 % of the RMS with the
                     offset, is 14 times that of y0 = 0; stated errors of m, k 0.25 % against a spread
                     of about 0.22 %)
    random-sub-y0=0  modal (SSI) found 25/25, omega -0.22 [-1.29, +0.57], zeta -3.2 [-16, +5.0];
                     io omega +0.0036 [-0.0067, +0.011], io zeta -0.14 [-0.41, +0.076], io coverage 1.00 [0.70, 1.00];
                     m +0.002 [-0.055, +0.041], c -0.11 [-0.18, -0.019], k +0.006 [-0.057, +0.036];
                     coverage 0.93 [0.73, 1.00] (c and the io zeta carry Euler's -0.1 %)
    impulse-me       modal omega +0.0036 [-0.0032, +0.0079], zeta -0.016 [-0.094, +0.10];
                     io omega -0.011 [-0.035, +0.0097], io zeta -0.030 [-0.46, +0.47], io coverage 1.00 [1.00, 1.00];
                     m +0.056 [-0.13, +0.20], c +0.040 [-0.41, +0.50], k +0.053 [-0.15, +0.19];
                     offset 1.000 mm; coverage 1.00 [0.93, 1.00]
    impulse-me-y0=0  modal omega +0.0012 [-0.0025, +0.0055], zeta -0.0069 [-0.068, +0.076];
                     io omega -0.012 [-0.036, +0.0087], io zeta -0.028 [-0.43, +0.51], io coverage 1.00 [0.90, 1.00];
                     m +0.050 [-0.11, +0.19], c +0.072 [-0.42, +0.51], k +0.011 [-0.12, +0.19];
                     coverage 1.00 [0.87, 1.00]

Before (seeds 0-4, 100 substeps, commit 202d97e): random-sub modal omega
-0.18 [-0.48, +0.08], zeta -11.9 [-18, -5] (the offset was in the
covariances: 4000 block rows), c -1.07, coverage 0.60; random-sub-y0=0
c -1.01, coverage 0.67; impulse-me-y0=0 modal omega -0.0005, zeta +0.03,
m -0.05, c +0.10, k -0.03, coverage 0.87 [0.67, 1.00].

    (offset: the least-squares estimate per run and record, mm)
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.stats import binomtest

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


def one(case: str, fmu: Path, seed: int, substeps: int, work: Path, first: bool) -> dict[str, list[float]]:
    """Errors (%, signed) per quantity over the repetitions of one seed, and the coverage."""
    path = work / f"{case}-{seed}.toml"
    path.write_text(campaign_text(case, fmu, seed, substeps))
    out = work / f"{case}-{seed}"
    status = sb.run_campaign(path, out, jobs=1, check_step="auto" if first else "off")  # the check once per case
    if status.failed:
        raise SystemExit(f"{case} seed {seed}: {[t.error for t in status.tests.values()]}")
    for warning in status.warnings:
        print(f"  {case}: {warning['message']}")
    errors: dict[str, list[float]] = {"omega": [], "zeta": [], "mass[1]": [], "damping[3]": [], "stiffness[2]": []}
    errors["modal missed"] = [0.0]
    held = []  # input-output intervals (omega, zeta) holding the truth
    for run in sb.identify(out, "modal", jobs=1)["runs"]:
        near = [j for j, w in enumerate(run["omega"]) if abs(w / OMEGA - 1) < 0.1]
        if not near:  # no mode reported within 10 %: counted, left out of the errors
            errors["modal missed"][0] += 1
            continue
        j = min(near, key=lambda j: abs(run["omega"][j] - OMEGA))
        errors["omega"].append(100 * (run["omega"][j] / OMEGA - 1))
        errors["zeta"].append(100 * (run["damping"][j] / ZETA - 1))
        io = run["details"]["input_output"]
        if io.get("poles_refined", [False] * (j + 1))[j]:  # the FRF fit with the measured force
            w, z, sw, sz = io["omega"][j], io["damping"][j], io["omega_std"][j], io["damping_std"][j]
            errors.setdefault("io omega", []).append(100 * (w / OMEGA - 1))
            errors.setdefault("io zeta", []).append(100 * (z / ZETA - 1))
            held += [abs(w - OMEGA) <= 1.96 * sw, abs(z - ZETA) <= 1.96 * sz]
        else:
            errors["io missed"] = errors.get("io missed", [0.0])
            errors["io missed"][0] += 1
    errors["io coverage"] = [float(np.mean(held))] if held else []
    inside = []
    for run in sb.identify(out, "least-squares", model=str(MODEL), jobs=1)["runs"]:
        for p in run["parameters"]:
            truth = TRUE[p["label"]]
            errors[p["label"]].append(100 * (p["value"] / truth - 1))
            errors.setdefault(f"std {p['label']}", []).append(100 * p["std_error"] / truth)
            inside.append(abs(p["value"] - truth) <= 1.96 * p["std_error"])
        errors.setdefault("offset (mm)", []).extend(1e3 * v for o in run["details"].get("offsets", {}).values()
                                                   for v in o.values())
    errors["coverage"] = [float(np.mean(inside))]
    errors["held"] = [float(x) for x in inside]
    errors["io held"] = [float(x) for x in held]
    return errors


def pooled_coverage(held: list[float]) -> str:
    """``k/n = share [lo, hi]``: the intervals holding the truth over every
    (seed, repetition, parameter), with the 95 % Clopper-Pearson interval of the share."""
    k, n = int(sum(held)), len(held)
    ci = binomtest(k, n).proportion_ci(0.95, method="exact")
    return f"{k}/{n} = {k / n:.3f} [{ci.low:.3f}, {ci.high:.3f}]"


def calibration(pooled: dict[str, list[float]]) -> list[str]:
    """Per parameter: the median stated standard error over the runs divided by
    the achieved spread (std of the estimates over every run, ddof 1; its own
    sampling error about 1 / sqrt(2 (N - 1))), and the mean error over the
    stated error (bias in standard errors; sampling error about 1 / sqrt(N))."""
    cells = []
    for label in TRUE:
        err, std = np.asarray(pooled.get(label, [])), np.asarray(pooled.get(f"std {label}", []))
        if err.size < 2:
            continue
        cells.append(f"{label} stated/achieved {np.median(std) / np.std(err, ddof=1):.3f} "
                     f"(+-{1 / np.sqrt(2 * (err.size - 1)):.3f}), mean error/stated {np.mean(err / std):+.3f} "
                     f"(+-{1 / np.sqrt(err.size):.3f}), N {err.size}")
    return cells


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5, help="campaign seeds per case (each: 5 repetitions)")
    parser.add_argument("--first", type=int, default=200, help="first campaign seed (tuned on: 100-104)")
    parser.add_argument("--substeps", type=int, default=1000, help="doSteps per sample of the random cases")
    parser.add_argument("--no-check-step", action="store_true",
                        help="skip the step-convergence check (run on each case's first seed otherwise)")
    parser.add_argument("--save", type=Path, help="write every run's values per case to SAVE/<case>.json")
    parser.add_argument("--cases", nargs="*", default=["impulse-me", "impulse-me-y0=0", "random-sub",
                                                        "random-sub-y0=0"])
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        fmu = build_msd(work)
        print(f"1-DOF FMU: m = {M} kg, k = {K:g} N/m, d = {D} N s/m (omega {OMEGA:g} rad/s, zeta {ZETA:g}); "
              f"{args.seeds} seeds x 5 repetitions, 2 % noise on force and position")
        print("errors in % of the true value: median [10th, 90th percentile] over every run; "
              "coverage: median [min, max] over seeds; pooled coverage: k of n (run, parameter) "
              "intervals holding the truth, share [95 % Clopper-Pearson interval]")
        for case in args.cases:
            start = time.monotonic()
            pooled: dict[str, list[float]] = {}
            for seed in range(args.first, args.first + args.seeds):
                for key, values in one(case, fmu, seed, args.substeps, work, seed == args.first and not args.no_check_step).items():
                    pooled.setdefault(key, []).extend(values)
            cells = [f"modal found the mode in {5 * args.seeds - int(sum(pooled.pop('modal missed')))}/"
                     f"{5 * args.seeds} runs, input-output fit missed {int(sum(pooled.pop('io missed', [0])))}"]
            if args.save:
                args.save.mkdir(parents=True, exist_ok=True)
                (args.save / f"{case}.json").write_text(json.dumps(pooled))
            held, io_held = pooled.pop("held"), pooled.pop("io held")
            for key, values in pooled.items():
                if not values or key.startswith("std "):  # no offsets estimated; standard errors below
                    continue
                v = np.asarray(values)
                ratio = key.endswith("coverage")
                lo, mid, hi = (np.percentile(v, [10, 50, 90]) if not ratio else (v.min(), np.median(v), v.max()))
                cells.append(f"{key} {mid:+.3g} [{lo:+.3g}, {hi:+.3g}]" if not ratio
                             else f"{key} {mid:.2f} [{lo:.2f}, {hi:.2f}]")
            cells.append(f"pooled coverage {pooled_coverage(held)}")
            if io_held:
                cells.append(f"io pooled coverage {pooled_coverage(io_held)}")
            print(f"{case:16s} ({time.monotonic() - start:.0f} s): " + "; ".join(cells + calibration(pooled)),
                  flush=True)


if __name__ == "__main__":
    main()
