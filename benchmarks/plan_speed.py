"""Time ``structbench plan`` (modal layout) for a 1,000-DOF model with 2,000
candidate channels (displacement and velocity at every DOF), budget 20,
with the default layout criterion (``frequencies``; all three layouts are
computed in any case).

The model: a 500-element simply supported beam (m = 1 kg/m,
EI = 1 N m^2, L = 10 m; 501 nodes, 1,000 DOF) with Rayleigh damping; an
impulse free decay of 200 s at dt = 0.05 s with 2 % noise. Prints the wall
time of the plan call (target <= 10 s), its CPU time over every thread (on
a machine shared with other jobs the wall time measures the load; the CPU
time bounds the wall time on two idle cores), and each layout's figures.

    python benchmarks/plan_speed.py
"""
from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
import plan_models  # noqa: E402

import structbench as sb  # noqa: E402


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        model = plan_models.ch5_fe_beam(folder / "beam500.toml", elements=500)
        (folder / "c.toml").write_text(f"""name = "speed"
structure = "{model.name}"
[[tests]]
name = "impulse"
dt = 0.05
duration = 200.0
noise = {{sensor = 0.02}}
[[tests.excitation]]
kind = "impulse"
node = 37
dir = "w"
impulse = 1.0
method = "initial-velocity"
[[tests.sensors]]
nodes = [100, 200, 300, 400]
dirs = ["w"]
quantities = ["displacement"]
""")
        (folder / "cand.toml").write_text('[[candidates]]\nnodes = "all"\nquantities = ["displacement", "velocity"]\n')
        start, cpu = time.perf_counter(), time.process_time()
        doc = sb.plan(folder / "c.toml", "modal", candidates=folder / "cand.toml", sensors=20,
                      layout_out=folder / "layout.toml")
        wall, cpu = time.perf_counter() - start, time.process_time() - cpu
        lay = doc["layout"]
        print(f"plan, 1,000 DOF, {lay['candidates']} candidate channels, budget 20: {wall:.2f} s "
              f"wall, {cpu:.2f} s CPU (target <= 10 s); {len(lay['modes_planned'])} modes planned; "
              f"criterion {lay['criterion']}, chosen {lay['chosen']}")
        for name, row in lay["layouts"].items():
            print(f"  {name:24s} log det = {row['log_det']:.1f}, RMS predicted omega std / omega = "
                  f"{row['rms_rel_omega_std']:.3e}")


if __name__ == "__main__":
    main()
