"""Damage localisation by model updating from a baseline (issue 23.3).

Per seed ``s``: the campaigns ``campaigns/damage-baseline.toml`` (healthy
25-element cantilever, 5 velocity sensors, 2 % noise, 300 s of an unmeasured
random tip force, its ``[prior]`` a design model within 5 %) and
``campaigns/damage-damaged.toml`` (element 12 at 80 % stiffness) are run
with their ``seed`` (and the prior's) offset by ``s``; each folder gets
``identify --method modal``; the baseline ``identify --method updating``
from its ``[prior]``; the damaged folder ``identify --method updating
--prior BASELINE/results/updating.json --option localise=true`` (forward
stepwise selection, identifier/updating/localise.py) on the modes paired
one to one with a baseline mode within 3 % in frequency (``--option modes=[...]``;
``--all-modes``: every mode found); ``score`` flags the parameters
whose change exceeds 3 standard errors (bench/evaluation/damage_scores.py).
Prints per seed the flagged elements and the change found for element 12
(with the baseline's own part of its error: ``0.8 k_true / k_baseline - 0.8``
in points, what a method that found the change from the baseline exactly
would be off by), then how often it was found, its size error and the false
flags.

Targets: element 12 found in >= 19 of 20 seeds, its loss within 2
percentage points, no other element flagged in more than 1 of 20.
Weights: since the modal method states its shapes' errors
(``mode_shapes_std``, jackknife for this random response) the updating
uses them (``SHAPE_STD`` None; ``--shape-std X`` fills only entries
without one). The older runs below stated 0.01 of its shape's largest
for every shape entry.
Constants (``Z_FLAG`` = 3, ``shape_std`` = 0.01, the prior's 5 %) were
chosen on synthetic modal data and calibration seeds 101-103, then the
one-to-one mode pairing and ``level`` = 0.001 (was 0.01) on calibration
seeds 104-113, after two evaluations on seeds 1-20; the figures reported
for the final settings are from seeds 21-40, never looked at before.

Measured (about 17 s per seed on 2 shared cores; the modal identifier was
being changed meanwhile, so its modes differ slightly from run to run):

- level 0.01, every mode found, seeds 1-20: found 19 of 20,
  within 2 points 11 of 19, element 25 falsely flagged in 4 of 20;
- level 0.01, modes paired one to one, seeds 1-20: found 20 of 20, within
  2 points 11 of 20 (median |error| 1.76, largest 5.94), element 25
  falsely flagged in 3 of 20 (7 seeds with a false flag);
- level 0.001, modes paired one to one, held-out seeds 21-40 (the
  defaults): found 20 of 20 (target met); change -16.3 to -23.2 %, within
  2 points in 13 of 20 (median |error| 0.93, largest 3.71; the per-seed
  target is not met); falsely flagged: elements 5, 7, 20 once each, no
  element in more than 1 of 20 (target met).

With the modal method's own shape errors (issue 23, no new constant):
calibration seeds 101-112, stated errors against the old 0.01 on the same
modal results: found 12 / 12 both; within 2 pp 8 / 12 (median |error|
1.40, largest 3.57) against 9 / 12 (1.02, 7.13); seeds with a false flag
1 against 3. Fresh seeds 41-60 (never looked at before; run once, final
code, about 40-260 s per seed on 2 loaded cores): found 20 of 20 (target
met); change within 2 points in 12 of 20 (median |error| 1.01, mean
-1.54, largest 6.91: the per-seed target is missed, the loss is
overestimated in 18 of 20); falsely flagged elements 2, 10, 11, 18, 25
once each, no element in more than 1 of 20 (target met; 5 seeds with a
false flag). The jackknife's shape errors on this beam (40 random
responses of 300 s, seed 777, not a benchmark seed) are conservative for
modes 1-6 and about half the spread for modes 7-8, which the updating then
overweights: a likely part of the size bias.

With the shape errors adding the scatter over model orders (issue 23,
benchmarks/modal_shape_coverage.py; its constants chosen on that
benchmark's tuning seeds 113-140, none on this benchmark), fresh seeds
61-80, run once on 203879f (about 27 s per seed): found 19 of 20 (seed 78:
nothing flagged, the first F test 19.97 against 20.38, the damaged
record's mode 7 reported from a pole that split the mode, chi^2 1504 of
its shape against the model); within 2 points 17 of the 19 found (median
|error| 0.72, mean -0.53, largest 6.60 on seed 80, +2.39 on seed 77);
falsely flagged element 14 in 2 of 20 (seeds 75, 80; 9 and 18 once):
the false-flag target missed. The reported pole's distance from its
mode's median shape then entered the shape errors where it stands out
(af74beb; seeds 61-80 not rerun on it). Fresh seeds 81-100, run once on
af74beb (about 12 s per seed, quiet machine): found 20 of 20 (target
met); change within 2 points in 19 of 20 (median |error| 0.70, quartiles
0.41 and 1.07, mean -0.13, overestimated in 8 of 20; largest -4.33 on
seed 90, where element 14 entered the selection beside element 12: the
per-seed target is missed by that seed); falsely flagged elements 14, 19,
20, 22 once each (seed 81 two of them), no element in more than 1 of 20
(target met; 3 seeds with a false flag).

Seed 90 (run again on 83cae3e: the same -4.33 points): element 14 entered beside
element 12 by a partial F of 27.9 (threshold 20.3), and a fit of element 12
alone is -3.19 points off too. The data see the baseline's own error: at the
truth's changes relative to the baseline (-21.1 % for element 12, -4 to +4 %
for the others) the misfit is 33 on 50 data, with only element 12 changed
82. The F test's null fixed every unselected element at the baseline, so
that error, a combination of the candidates' columns, counted as evidence
for a neighbour; a backward check cannot drop it (its partial F given element
12 is the same 27.9). Since 494422f each step is tested by the likelihood
ratio of linear mixed models in which the unselected elements scatter about
the baseline with a variance the data estimate (identifier/updating/
localise.py); the sizes are still the fixed-effect fit of the selected set.
No constant was added or tuned (level 0.001 and the Bonferroni bound as
before). Calibration seeds 101-140 on cached modal results (the old search
run on them first): found 39 of 40 both (seed 123: the baseline's modal
result held two duplicate modes, its update ran every stiffness onto the
lower bound, nothing to localise from); seeds with a false flag 5 (elements
3, 11, 14, 17, 19 once each) against 0; within 2 points 38 of 39 both (seed
101: +4.66 against +2.25, where the baseline's own part is +2.91); seed 90:
-4.33 against -3.19. The first step's F for element 12 dropped (561 to 68 on seed 90: without
it the random effects take part of the change), its smallest 27.6 against
20.4 (seed 127).

Fresh seeds 141-160, run once on a clean copy of 494422f (about 10-24 s
per seed on 2 loaded cores): found 20 of 20 (target met); within 2 points
20 of 20 (target met; median |error| 0.71, quartiles -0.70 and +0.63, mean
-0.10, largest -1.82 on seed 142, overestimated in 12 of 20); no element
falsely flagged in any seed (target met). The first step's F 42.7-131.4
against 20.4; the second step's largest 13.5 (element 25, seed 146). The
baseline's own part of the error was beyond 2 points in 6 of 20 seeds
(median |.| 1.23), so with five sensors and a 5 % prior the per-seed size
target cannot be guaranteed on every seed; the fit of element 12 alone,
the others at the baseline, landed closer to the declared -20 % (median
|error| 0.71) than the change relative to the baseline (1.23).

Seed 123 (calibration): the baseline's modal result held modes 5 and 6
(252.6 and 256.8 rad/s, shapes MAC 0.999) and 9 and 10 (702.2 and 711.5,
MAC 0.976), one mode each reported twice. One-to-one pairing gave the
copies model modes 15 and 18 (2651 and 3888 rad/s at the prior: with five
sensors mode 15 looks like mode 5, MAC 1.00), eigenvalue residuals of about
15,000 standard errors, and the baseline update ran all 25 stiffnesses onto
the lower bound (-0.9), reported as converged. Since 83bcbd8 measured modes
that pair best with the same model mode at the prior and whose shapes agree
(MAC >= 0.9) keep the one closest to it and the others are left out and
named (identifier/updating/pairing.py; the 0.9 chosen on no seed, the two
copies here at 0.976 and 0.999), and a result with every parameter on a
bound is an error (this benchmark then counts the seed as not found).
Calibration seeds 101-140 rerun on the cached modal results with it: modes
left out in seed 123 only (baseline modes 6 and 10; no damaged record),
every other seed as before; seed 123: element 12 alone selected, -19.70 %
(+0.30 points; the baseline's part -1.85); overall found 40 of 40, within
2 points 39 of 40 (seed 101: +2.25), no element falsely flagged.

Fresh seeds 161-180, run once on a clean copy of 08c77a5 (14:40 UTC; about
9-12 s per seed, load average 16-19 on the 2 cores): found 20 of 20 (target
met); within 2 points 19 of 20 (median |error| 0.68, quartiles -0.67 and
+0.31, largest -2.47 on seed 165, where the baseline's part is -1.39: the
per-seed target missed by that seed); no element falsely flagged in any
seed (target met). The baseline's own part beyond 2 points in 5 of 20
(median |.| 1.15). The baselines of seeds 168 and 173 held a mode reported
twice (their modes 10 and 8 left out); the same modal results updated
without the check (run afterwards on the cached results) put 11 and 15
stiffnesses on a bound and localised nothing: both seeds would have been
missed.

    python benchmarks/updating_damage.py [--seeds 81-100] [--level 0.001] [--all-modes] [--shape-std X] [--work DIR]
"""
from __future__ import annotations

import argparse
import json
import re
import shutil
import time
from pathlib import Path

import numpy as np

import structbench as sb
from structbench.identifier.errors import IdentificationError

ROOT = Path(__file__).resolve().parents[1]
SHAPE_STD: float | None = None  # None: the modal results' own shape errors (mode_shapes_std); a number: for
# shape entries without one, relative to each shape's largest entry (0.01 before the modal method stated them)
DAMAGED = "stiffness[12]"
MATCH = 0.03      # relative frequency difference within which a damaged mode is the baseline's
COMMON = True     # update the damaged data only on the modes the baseline identified too
LEVEL = 0.001     # family-wise level of the stepwise F tests (0.01 until seeds 104-113 at 0.001)


def seeds(text: str) -> list[int]:
    a, _, b = text.partition("-")
    return list(range(int(a), int(b or a) + 1))


def campaign(name: str, work: Path, seed: int) -> Path:
    """A copy of ``campaigns/<name>.toml`` in ``work`` with every seed offset by ``seed``."""
    text = (ROOT / "campaigns" / f"{name}.toml").read_text()
    text = re.sub(r"(?m)^seed = (\d+)", lambda m: f"seed = {int(m.group(1)) + 100 * seed}", text)
    path = work / f"{name}-{seed}.toml"
    path.write_text(text)
    return path


def matched(base: np.ndarray, damaged: np.ndarray) -> list[int]:
    """Damaged modes (0-based, ascending) paired one to one with baseline
    modes, closest relative frequency first, within ``MATCH``: a duplicate
    or spurious mode the modal identifier reports beside a true one is left out."""
    gap = np.abs(np.log(damaged[None, :] / base[:, None]))
    used_b, used_d = set(), set()
    for flat in np.argsort(gap, axis=None):
        i, j = np.unravel_index(flat, gap.shape)
        if gap[i, j] < MATCH and i not in used_b and j not in used_d:
            used_b.add(i)
            used_d.add(j)
    return sorted(int(j) for j in used_d)


def one_seed(seed: int, work: Path) -> dict:
    base, damaged = work / f"base-{seed}", work / f"damaged-{seed}"
    for name, out in (("damage-baseline", base), ("damage-damaged", damaged)):
        shutil.rmtree(out, ignore_errors=True)
        status = sb.run_campaign(campaign(name, work, seed), out, jobs=0, fmu_dir=work / "fmus")
        assert status.failed == 0, status
        sb.identify(out, "modal", jobs=1)
    try:
        sb.identify(base, "updating", jobs=1, shape_std=SHAPE_STD)
    except IdentificationError as err:  # e.g. every parameter on a bound: no baseline, nothing to localise from
        print(f"seed {seed}: the baseline update failed: {err}", flush=True)
        return {"flagged": [], "found": False, "false": [], "change": np.nan, "std": np.nan, "error_pp": np.nan,
                "modes": [0, 0], "baseline_pp": np.nan, "left_out": []}
    omega = [np.array(json.loads((f / "results" / "modal.json").read_text())["runs"][0]["omega"])
             for f in (base, damaged)]
    # like with like: the damaged modes the baseline also identified (within MATCH) and was fitted to
    common = matched(omega[0], omega[1]) if COMMON else None
    sb.identify(damaged, "updating", jobs=1, prior=base / "results" / "updating.json", shape_std=SHAPE_STD,
                localise=True, level=LEVEL, modes=common)
    for out in (base, damaged):
        shutil.rmtree(out / "traces")  # 12 MB each
    run = sb.score(damaged)["updating"]["damage"]["runs"][0]
    i = run["labels"].index(DAMAGED)
    # the change the damaged data can see: relative to the baseline's value, not the truth's
    true = {p["label"]: p["value"] for p in json.loads((base / "truth.json").read_text())["parameters"]}
    fitted = json.loads((base / "results" / "updating.json").read_text())["runs"][0]["parameters"]
    baseline = {p["label"]: p["value"] for p in fitted}
    factor = 1.0 + run["declared"][DAMAGED]
    visible = factor * true[DAMAGED] / baseline[DAMAGED] - 1.0
    modes = [len(json.loads((f / "results" / "modal.json").read_text())["runs"][0]["omega"]) for f in (base, damaged)]
    left = [[d["mode"] for d in json.loads((f / "results" / "updating.json").read_text())["runs"][0]["details"]
             .get("left_out", [])] for f in (base, damaged)]
    return {"flagged": run["flagged"], "found": run["found"], "false": run["false"], "change": run["change"][i],
            "std": run["change_std"][i], "error_pp": run["size_error_pp"][DAMAGED], "modes": modes,
            "baseline_pp": 100.0 * (visible - run["declared"][DAMAGED]), "left_out": left}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="1-20")
    parser.add_argument("--work", type=Path, default=Path("/tmp/structbench-damage"))
    parser.add_argument("--all-modes", action="store_true", help="update the damaged data on every mode found")
    parser.add_argument("--level", type=float, default=LEVEL)
    parser.add_argument("--shape-std", type=float, default=SHAPE_STD,
                        help="shape error for entries the modal results state none for (default: none)")
    args = parser.parse_args()
    globals().update(COMMON=not args.all_modes, LEVEL=args.level, SHAPE_STD=args.shape_std)
    args.work.mkdir(parents=True, exist_ok=True)
    shutil.copy(ROOT / "campaigns" / "cantilever-25.toml", args.work / "cantilever-25.toml")
    rows = []
    for seed in seeds(args.seeds):
        start = time.perf_counter()
        r = one_seed(seed, args.work)
        rows.append(r)
        if not np.isfinite(r["change"]):
            continue
        out = f"  left out (repeated modes) {r['left_out']}" if any(r["left_out"]) else ""
        print(f"seed {seed:3d}: modes {r['modes'][0]}/{r['modes'][1]}  flagged {', '.join(r['flagged']) or 'none':40s} "
              f"{DAMAGED} {100 * r['change']:+6.2f} % +- {100 * r['std']:.2f} (error {r['error_pp']:+.2f} pp, "
              f"the baseline's part {r['baseline_pp']:+.2f})  "
              f"{time.perf_counter() - start:.0f} s{out}", flush=True)
    n = len(rows)
    found = sum(r["found"] for r in rows)
    errors = np.array([r["error_pp"] for r in rows if r["found"]])
    false: dict[str, int] = {}
    for r in rows:
        for lab in r["false"]:
            false[lab] = false.get(lab, 0) + 1
    print(f"\n{DAMAGED} found in {found} of {n} seeds (target >= {n - 1 if n >= 20 else n}); "
          f"size error of the found (pp): median {np.median(np.abs(errors)) if errors.size else np.nan:.2f}, "
          f"max {np.max(np.abs(errors)) if errors.size else np.nan:.2f}, within 2 pp in "
          f"{int(np.sum(np.abs(errors) <= 2))} of {found}; quartiles of the error "
          + (f"{np.percentile(errors, 25):+.2f}, {np.percentile(errors, 75):+.2f}" if errors.size else "none"))
    part = np.array([r["baseline_pp"] for r in rows if np.isfinite(r["baseline_pp"])])
    print(f"the baseline's own part of the error (its value of {DAMAGED} against the truth's, times the factor): "
          f"median |.| {np.median(np.abs(part)):.2f} pp, beyond 2 pp in {int(np.sum(np.abs(part) > 2))} of {n}")
    print("falsely flagged (element: seeds): " + (", ".join(f"{k}: {v}" for k, v in sorted(false.items())) or "none")
          + f"; most often {max(false.values()) if false else 0} of {n} (target <= 1)")


if __name__ == "__main__":
    main()
