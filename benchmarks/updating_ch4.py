"""Model updating on the chapter 4 cantilevers with the dissertation's noise (issue 23.4).

Two routes per case; ``--routes frf,modal`` (default both).

FRF route (``structbench identify DIR --method updating --option data=frf``,
the registry resolving the built-in ``-postulated`` prior as on the command
line; the truth only scores): FRF lines from the 12 stepped-sine tests of
each repetition (forced plus free-vibration fit, excitation frequency
tracked: ``identifier/updating/frf_data.py``), whitened real/imaginary
residuals with the declared 0.5 % actuator amplitude error as a per-line
gain (``frf_residuals.py``). Printed: normalized RMS parameter error per
repetition, median and 10-90 % spread, the share of 95 % intervals
(1.96 ``std_error``) that hold the truth, and how many runs added the
records' natural frequencies (only when the FRFs alone are rank-deficient).

Measured (20 repetitions each, 2 processes on a 2-core machine; the
figures are the same before and after the free-vibration fits were made
faster, the times after):
case 1, median 0.00119, 10-90 % 0.00026 .. 0.00231, max 0.00263 (target
0.005 met; postulated 0.122), intervals cover 99.6 % of 240 estimates,
FRFs alone full rank (no natural frequencies added), 68 s wall;
case 2 (one tip sensor), median 5.8e-6, 10-90 % 3.5e-6 .. 9.6e-6, max
1.1e-5 (target 0.01 met; postulated 0.029), intervals cover 99.6 %, every
run added the records' natural frequencies (the tip FRFs of an undamped
structure give one real number per line: rank-deficient alone), 42 s
wall. The intervals are conservative (the discrepancy-principle
regulariser and the inflated natural-frequency errors widen them).
Re-measured on a clean copy of 83bcbd8 (the duplicate-mode check and the
refusal of all-on-a-bound results; 20 repetitions each, run once, the
cached campaigns, load average 11-13 on the 2 cores from other runs):
case 1 median 0.00119, 10-90 % 0.00026 .. 0.00231, max 0.00263, cover
99.6 % of 240, no natural frequencies added, 283 s wall; case 2 median
5.78e-6, 10-90 % 3.50e-6 .. 9.55e-6, max 1.07e-5, cover 99.6 %, every run
added the natural frequencies, 122 s wall: the same figures (both targets
met). The modal route stopped on that commit (the modal identifier's
``judge()`` got an argument ``spectrum`` its committed support.py did not
take yet) and ran on a clean copy of 7bc5ce2 instead (once, load 5-11).
An earlier version without the natural-frequency guide of the search and
without leaving out lines unresolvable from a natural frequency ended 7 of
the 20 case 1 repetitions in a wrong basin (0.47 to 1.93).

Modal route (the modal identifier, then updating from its modes):
Per case (``campaigns/ch4-case1.toml``: all 12 DOF measured, 1 % sensor and
0.5 % actuator noise; ``ch4-case2.toml``: one tip sensor, 0.01 % and
0.0005 %): the campaign is run, each of the 20 repetitions of its ``noisy``
stepped sine (12 tests of 200 s) goes through ``identify --method modal``
(one run per repetition) and the modes found update the built-in
``-postulated`` model (Table 4.1's postulated values, the default prior of
``--method updating``), exactly as ``structbench identify DIR --method
updating`` does, run by run so that a run without modes does not stop the
others. Printed: modes found, normalized RMS parameter error per
repetition, median and 10-90 % spread, the postulated model's error and
whether the issue's target is met (case 1: median <= 0.005; case 2: <= 0.01).

A second line per case is the best the data type allows: updating from the
true modes (every mode, exact, at the case's sensors), which still cannot
separate a common scale of mass and stiffness (eigenvalues and unscaled
shapes are unchanged by it): that direction stays at the prior.

Measured (20 repetitions each): case 1, the modal identifier finds 0 to 2
modes in these undamped stepped-sine records (14 of 20 repetitions none:
the forced harmonics and the undecaying free vibration fail its support
tests), so no median (the 6 runs with modes: 0.085 to 2.06; postulated
0.122); case 2, 2 to 4 modes at the tip, median 0.098 (10-90 %: 0.037 ..
0.206), worse than the postulated 0.029. Targets (0.005, 0.01) not met.
From the exact true modes the floor is 0.081 (case 1) and 0.026 (case 2):
rank 11 of 12, the common scale of mass and stiffness stays at the prior.
Modal data without a measured force cannot meet these targets with mass
and stiffness both unknown.
Re-measured on 7bc5ce2 (the modal identifier now finds more modes in these
records): case 1, 2 to 6 modes per repetition, normalized RMS median 0.894
counting repetition 13 as a failure (of the 19 others 0.889, 10-90 %
0.087 .. 1.81; 8 of them 0.08-0.15, the rest 0.86-1.93: wrong basins);
repetition 13 refused, every parameter on a bound (its modes 1 and 2, 29.5
and 61.8 rad/s, paired with model modes 5 and 6 at 5.4 and 7.8 rad/s);
case 2, 3 to 5 modes, median 0.0379 (10-90 % 0.0324 .. 0.952; 15 of 20 at
0.031-0.042, 5 at 0.67-1.57); the floors from the exact true modes 0.0806
and 0.0256 as before. Targets not met by this route.

    python benchmarks/updating_ch4.py [--work DIR] [--cases 1,2] [--routes frf,modal] [--jobs 2]
"""
from __future__ import annotations

import argparse
import json
import shutil
import time
from pathlib import Path

import numpy as np

import structbench as sb
from structbench.identifier.errors import IdentificationError
from structbench.identifier.updating import ModalData, update
from structbench.identifier.updating.data import from_run
from structbench.models import load_model

ROOT = Path(__file__).resolve().parents[1]
TARGET = {1: 0.005, 2: 0.01}


def nrms(values: np.ndarray, truth: np.ndarray) -> float:
    return float(np.sqrt(np.mean((values / truth - 1.0) ** 2)))


def frf_route(number: int, out: Path, truth: np.ndarray, labels: list[str], start: float, jobs: int) -> None:
    """``identify DIR --method updating --option data=frf`` on the noisy group
    (the prior: the built-in ``-postulated`` model, resolved by the registry
    as on the command line); the truth only scores the results."""
    began = time.perf_counter()
    doc = sb.identify(out, "updating", groups=["noisy"], jobs=jobs, data="frf", tag="frf")
    wall = time.perf_counter() - began
    runs = sorted(doc["runs"], key=lambda r: r["repetition"])
    e, inside, natural = [], [], 0
    for run in runs:
        est = {p["label"]: p for p in run["parameters"]}
        values = np.array([est[lab]["value"] for lab in labels])
        std = np.array([est[lab]["std_error"] if est[lab]["std_error"] is not None else np.nan for lab in labels])
        e.append(nrms(values, truth))
        inside.append(np.abs(values - truth) <= 1.96 * std)
        natural += "natural_frequencies" in run["details"]
    e = np.array(e)
    inside = np.array(inside)
    med = float(np.median(e))
    print(f"  FRF residuals (data=frf, {len(runs)} repetitions, {wall:.0f} s wall on {jobs} process(es)): "
          f"normalized RMS median {med:.2e}, 10-90 % {np.percentile(e, 10):.2e} .. {np.percentile(e, 90):.2e}, "
          f"max {e.max():.2e}; postulated {start:.4f}; target <= {TARGET[number]}: "
          f"{'met' if med <= TARGET[number] else 'NOT met'}")
    print(f"    per repetition: {' '.join(f'{v:.2e}' for v in e)}")
    print(f"    95 % intervals (1.96 std_error) cover the truth for {inside.mean():.1%} of the "
          f"{inside.size} parameter estimates; runs that added the records' natural frequencies: {natural}")


def case(number: int, work: Path, routes: set[str], jobs: int) -> None:
    out = work / f"ch4-case{number}"
    if not (out / "truth.json").is_file():
        shutil.rmtree(out, ignore_errors=True)
    status = sb.run_campaign(ROOT / "campaigns" / f"ch4-case{number}.toml", out, jobs=1)  # resumes: a done run is kept
    assert status.failed == 0, status
    truth_doc = json.loads((out / "truth.json").read_text())
    true = {p["label"]: p["value"] for p in truth_doc["parameters"]}
    prior = load_model(f"ch4-cantilever-case{number}-postulated")
    mask = prior.kind_mask()
    labels = [p.label for p, m in zip(prior.parameters, mask) if m]
    truth = np.array([true[lab] for lab in labels])
    start = nrms(prior.values[mask], truth)
    print(f"case {number}:")
    if "frf" in routes:
        frf_route(number, out, truth, labels, start, jobs)
    if "modal" not in routes:
        return
    modal = sb.identify(out, "modal", groups=["noisy"], jobs=1)
    errors, found = [], []
    for run in modal["runs"]:
        found.append(len(run["omega"]))
        try:
            result = update(prior, from_run(run, f"repetition {run['repetition']}"))
            errors.append(nrms(result.values(), truth))
        except IdentificationError as err:
            errors.append(np.nan)
            print(f"  repetition {run['repetition']}: {err}")
    e = np.array(errors)
    ok = np.isfinite(e)
    print(f"case {number}: modes found per repetition {found}")
    print(f"  normalized RMS per repetition: {' '.join(f'{v:.4f}' for v in e)}")
    if ok.any():
        med = float(np.median(np.where(ok, e, np.inf)))  # a run without modes counts as a failure
        shown = f"{med:.4f}" if np.isfinite(med) else "none (over half the runs without modes)"
        print(f"  median {shown}; of the {int(ok.sum())} runs with modes: median {np.median(e[ok]):.4f}, "
              f"10-90 % {np.percentile(e[ok], 10):.4f} .. {np.percentile(e[ok], 90):.4f}; postulated {start:.4f}; "
              f"target <= {TARGET[number]}: {'met' if med <= TARGET[number] else 'NOT met'}")
    else:
        print(f"  no repetition gave modes to update from; postulated {start:.4f}; target <= {TARGET[number]}: NOT met")
    actual = load_model(f"ch4-cantilever-case{number}")
    sensors = [tuple(d) for d in truth_doc["sensor_dofs"]]
    modes = actual.modes()
    shapes = modes.shapes[[actual.dof_index(*d) for d in sensors]]
    exact = ModalData(modes.lam, np.full(modes.lam.size, np.nan), shapes / np.abs(shapes).max(axis=0),
                      np.full(shapes.shape, np.nan), sensors, "true modes")
    best = update(prior, exact)
    print(f"  from the exact true modes ({modes.lam.size}, at {len(sensors)} sensor DOF): normalized RMS "
          f"{nrms(best.values(), truth):.4f}, rank {best.details['identifiability']['rank']} of {len(labels)}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", type=Path, default=Path("/tmp/structbench-ch4-updating"))
    parser.add_argument("--cases", default="1,2")
    parser.add_argument("--routes", default="frf,modal", help="frf (FRF residuals), modal (identified modes) or both")
    parser.add_argument("--jobs", type=int, default=2, help="processes of the FRF route (one repetition each)")
    args = parser.parse_args()
    args.work.mkdir(parents=True, exist_ok=True)
    for number in (int(c) for c in args.cases.split(",")):
        case(number, args.work, set(args.routes.split(",")), args.jobs)


if __name__ == "__main__":
    main()
