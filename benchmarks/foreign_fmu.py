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
``details.input_output``). Coverage of the 95 % intervals (value +- 1.96
standard errors) of least squares (m, c, k) and of the input-output poles
(omega, zeta): per seed, median [min, max] (15 intervals per seed cannot
tell 95 % from 100 %: exact intervals give 1.00 with probability
0.95^15 = 0.46); and pooled over every (seed, repetition, parameter),
k of n with the 95 % Clopper-Pearson interval of the share. Per parameter:
the median stated standard error over the achieved spread (std of the
estimates over every run, ddof 1; sampling error about 1 / sqrt(2 (N - 1)))
and the mean of error / stated error (sampling error about 1 / sqrt(N)).
With a measured force, ``--option input=poles`` makes the ``io`` poles and
their standard errors ``modal``'s reported omega and zeta (commit 63c3efa;
the SSI's stay in ``details.ssi``): the issue's one-sensor target (omega
within 0.1 %, zeta within 5 %) is met by them in every case below, and
missed by output-only SSI's omega in the random cases.

    python benchmarks/foreign_fmu.py --seeds 5 [--first 200] [--no-check-step] [--save DIR]

Developed on seeds 100-104 (and exact numpy simulations, seeds 0-17, for
identifier/modal/residues.py). Fresh seeds, each run once with
--no-check-step on a clean copy of commit 9f07e22, beside other helpers'
benchmarks (load 5-13 on 2 cores): impulse cases seeds 205-224 (100 runs
per case, 470-520 s per case), random cases seeds 225-240 (80 runs per
case, two processes of 8 seeds, 2100-2830 s each; pooled from their
``--save`` files). Median [p10, p90] over the runs, %:

    random-sub       modal (SSI) found 78/80, omega -0.25 [-1.5, +1.2], zeta -4.1 [-32, +8.1];
                     io omega -0.0018 [-0.022, +0.020], io zeta -0.055 [-0.40, +0.48],
                     io coverage 144/156 = 0.923 [0.869, 0.960];
                     m -0.024 [-0.41, +0.30], c -0.071 [-0.44, +0.23], k -0.032 [-0.40, +0.29]; offset 1.000 mm;
                     coverage 228/240 = 0.950 [0.914, 0.974], per seed 1.00 [0.80, 1.00];
                     stated/achieved m 0.95, c 0.98, k 0.95 (+-0.08); mean z m -0.06, c -0.29, k -0.06 (+-0.11)
    random-sub-y0=0  modal (SSI) found 80/80, omega -0.25 [-1.1, +1.1], zeta -1.5 [-15, +4.0];
                     io omega -0.0002 [-0.0092, +0.0098], io zeta -0.092 [-0.29, +0.18],
                     io coverage 155/160 = 0.969 [0.929, 0.990];
                     m -0.004 [-0.040, +0.037], c -0.089 [-0.20, +0.027], k -0.001 [-0.040, +0.035];
                     coverage 218/240 = 0.908 [0.865, 0.942], per seed 0.93 [0.73, 1.00];
                     stated/achieved m 1.08, c 0.91, k 1.07 (+-0.08); mean z m -0.09, c -1.09, k -0.10 (+-0.11)
                     (c and the io zeta carry the simulation's Euler -0.1 %: c's interval holds
                     the truth in 63 of 80 runs, m's and k's in 77 and 78)
    impulse-me       modal (SSI) found 100/100, omega -0.0005 [-0.0057, +0.0058], zeta -0.018 [-0.10, +0.12];
                     io omega +0.0096 [-0.025, +0.041], io zeta +0.055 [-0.66, +0.81],
                     io coverage 194/200 = 0.970 [0.936, 0.989];
                     m -0.001 [-0.20, +0.17], c +0.061 [-0.63, +0.63], k +0.003 [-0.19, +0.17]; offset 1.000 mm;
                     coverage 280/300 = 0.933 [0.899, 0.959], per seed 0.97 [0.80, 1.00];
                     stated/achieved m 0.95, c 0.90, k 0.92 (+-0.07); mean z m -0.03, c +0.14, k +0.04 (+-0.10)
    impulse-me-y0=0  modal (SSI) found 100/100, omega -0.0000 [-0.0042, +0.0043], zeta -0.006 [-0.083, +0.075];
                     io omega +0.0095 [-0.024, +0.039], io zeta +0.041 [-0.64, +0.81],
                     io coverage 192/200 = 0.960 [0.923, 0.983];
                     m -0.004 [-0.17, +0.13], c +0.056 [-0.63, +0.60], k -0.003 [-0.17, +0.16];
                     coverage 279/300 = 0.930 [0.895, 0.956], per seed 0.97 [0.80, 1.00];
                     stated/achieved m 0.99, c 0.92, k 0.94 (+-0.07); mean z m -0.02, c +0.13, k +0.04 (+-0.10)

(the impulse cases share their noise seeds, so their columns are not
independent). Re-run on the code of 51e9145 (27 Nov, quiet machine): the
impulse cases, seeds 205-224, the same to every digit printed; random-sub,
seeds 225-240 (two processes of 8 seeds, 581-583 s each): io omega -0.0018
[-0.022, +0.020], io zeta -0.081 [-0.38, +0.48], io coverage 146/158 =
0.924; m -0.024, c -0.071, k -0.032, coverage 228/240 = 0.950; output-only
SSI found 79/80, omega -0.24 [-1.2, +1.2], zeta -3.6. The stated standard errors with the 1 mm offset (noise 14
times that without it) match the achieved spread within its sampling error:
the earlier reading "0.25 % against about 0.22 %" (seeds 200-204, 25 runs,
sampling error 14 %) was noise. Exact zero-order-hold Monte Carlo of the
same oscillator (tests/identify_synth.py: one input, 1 mm offset, 2 %
noise, one record per run; noise seeds 1000-1039 for a 120 s force white
to Nyquist, 1 N rms, 1000-1199 for the 4 s 1 N s impulse) agrees:
stated/achieved m 0.98, k 0.95, c 1.15 (+-0.11) and 1.04, 1.04, 1.04
(+-0.05). On seeds 200-204 (commit 8213465) the per-seed coverage read
1.00 [1.00, 1.00], 0.93 [0.73, 1.00], 1.00 [0.93, 1.00], 1.00 [0.87, 1.00]
for the four cases.

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
