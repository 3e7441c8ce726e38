"""Excitation points ranked by ``structbench plan --drives`` against Monte Carlo.

The chapter 5 beam as 25 elements (``plan_models.ch5_fe_beam``, Rayleigh
damping), the free decay of ``plan_layout.py`` (1 N s impulse, 400 s at
dt = 0.05 s, 2 % sensor noise) seen by its 8 transverse displacement
sensors (nodes 3, 6, ..., 24); candidate drive points: the w of every inner
node (24). ``plan --drives --target-modes T`` (default 10, the modes
``plan_layout.py`` scores) ranks them; the best, the median-ranked and
the last-ranked point each run ``REPS`` repetitions (campaign seed 21)
through the FMU and the modal method. Per point: the predicted RMS of
``std(omega_r) / omega_r`` over the target modes it shows (the ranking's
figure), the Monte Carlo RMS relative error over the same modes (a mode not
found within 3 %: 3 %), per mode, and the modes it leaves invisible.
Prints the table.

    python benchmarks/plan_drives.py [--reps 10] [--jobs 2] [--target-modes 10]
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
import plan_layout  # noqa: E402
import plan_models  # noqa: E402

import structbench as sb  # noqa: E402
from structbench.planning.campaign_files import test_campaign  # noqa: E402


def rms_error(runs: list[dict], targets: np.ndarray) -> float:
    """RMS over runs and target modes of the relative frequency error (a miss: 3 %)."""
    return float(np.sqrt(np.mean(plan_layout.per_mode(runs, targets) ** 2)))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--reps", type=int, default=10)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--target-modes", type=int, default=10)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        model = plan_models.ch5_fe_beam(folder / "beam25.toml", elements=25)
        (folder / "c.toml").write_text(plan_layout.CAMPAIGN.format(model=model.name, node=4))
        (folder / "drives.toml").write_text('[[drives]]\nnodes = "all"\ndirs = ["w"]\n')
        doc = sb.plan(folder / "c.toml", "modal", drives=folder / "drives.toml", layout_out=folder / "best.toml",
                      target_modes=args.target_modes)
        ranking, targets = doc["drives"]["ranking"], np.asarray(doc["drives"]["target_modes"])
        print(f"{len(ranking)} candidate points, {targets.size} target modes; ranked: "
              + " ".join(f"{r['node']}" for r in ranking))
        picks = {"best": ranking[0], "median": ranking[len(ranking) // 2], "last": ranking[-1]}
        print(f"{'point':8s} {'node':>4s} {'missed':>6s} {'predicted':>10s} {'Monte Carlo':>12s} {'MC / predicted':>14s}")
        for name, row in picks.items():
            path = folder / f"{name}.toml"
            path.write_text(test_campaign(folder / "c.toml", "impulse", repetitions=args.reps, seed=21,
                                          drive=(row["node"], row["dir"])))
            assert not sb.run_campaign(path, folder / name, jobs=args.jobs).failed
            runs = sb.identify(folder / name, "modal", jobs=args.jobs)["runs"]
            seen = targets[~np.isin(targets, row["missed"])]
            got = rms_error(runs, seen)
            pred = row["rms_rel_omega_std"]
            print(f"{name:8s} {row['node']:4d} {len(row['missed']):6d} {pred:10.3e} {got:12.3e} {got / pred:14.2f}"
                  "   per mode: " + " ".join(f"{v:.1e}" for v in plan_layout.per_mode(runs, seen)))


if __name__ == "__main__":
    main()
