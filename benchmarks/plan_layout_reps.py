"""The planned layouts of ``plan_layout.py --candidates all`` with many
repetitions: how far its 5-run score is from the layout's own spread.

The chapter 5 beam as 25 elements (``plan_models.ch5_fe_beam``), the same
free decay and 50 candidate displacement channels (w and theta of every
DOF), budget 10; the layouts of criteria ``frequencies`` (``--target-modes
10``) and ``d-optimal``, each ``REPS`` repetitions (default 40) through the
FMU and the modal method under campaign seed 12 (a seed ``plan_layout.py``
does not use). Score as ``plan_layout.py`` (RMS relative error of
omega_1..10 over runs and modes, a miss 3 %), with the 10-90 % range of 500
bootstrap resamples of the runs (generator seed 0) and the bound's
prediction beside it.

    python benchmarks/plan_layout_reps.py [--reps 40] [--jobs 2]
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
from structbench.planning.campaign_files import dumps  # noqa: E402

NODE = 4  # the impulse at x = 1.2 m


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--reps", type=int, default=40)
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        model = plan_models.ch5_fe_beam(folder / "beam25.toml", elements=25)
        (folder / "c.toml").write_text(plan_layout.CAMPAIGN.format(model=model.name, node=NODE))
        (folder / "cand.toml").write_text('[[candidates]]\nnodes = "all"\nquantities = ["displacement"]\n')
        layouts, predicted = {}, {}
        for criterion in ("frequencies", "d-optimal"):
            lay = sb.plan(folder / "c.toml", "modal", candidates=folder / "cand.toml", sensors=10,
                          layout_out=folder / f"{criterion}.toml", criterion=criterion, target_modes=10)["layout"]
            layouts[criterion] = [tuple(s) for s in lay["sensors"]]
            predicted[criterion] = lay["layouts"][lay["chosen"]]["rms_rel_omega_std"]
        base = {"name": "reps", "structure": str(model), "seed": 12, "tests": [
            {"name": name, "dt": 0.05, "duration": 400.0, "repetitions": args.reps, "noise": {"sensor": 0.02},
             "excitation": [{"kind": "impulse", "node": NODE, "dir": "w", "impulse": 1.0,
                             "method": "initial-velocity"}],
             "sensors": [{"nodes": [n], "dirs": [d], "quantities": [q]} for n, d, q in sensors]}
            for name, sensors in layouts.items()]}
        (folder / "mc.toml").write_text(dumps(base))
        status = sb.run_campaign(folder / "mc.toml", folder / "mc", jobs=args.jobs)
        assert not status.failed
        results = sb.identify(folder / "mc", "modal", jobs=args.jobs)
        truth = np.asarray(sb.modes(str(model), 10)["omega"])
        rng = np.random.default_rng(0)
        for name in layouts:
            runs = [r for r in results["runs"] if r["tests"][0] == name]
            boot = [plan_layout.score([runs[i] for i in rng.integers(len(runs), size=len(runs))], truth)
                    for _ in range(500)]
            got = plan_layout.score(runs, truth)
            print(f"{name:12s} {len(runs)} runs: score {got:.3e} (bootstrap 10-90 % "
                  f"{np.percentile(boot, 10):.2e}-{np.percentile(boot, 90):.2e}); bound {predicted[name]:.3e} "
                  f"(achieved / bound {got / predicted[name]:.2f}); per mode "
                  + " ".join(f"{v:.1e}" for v in plan_layout.per_mode(runs, truth)))


if __name__ == "__main__":
    main()
