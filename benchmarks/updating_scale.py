"""Model updating at scale: a 1,000-DOF clamped beam, 50 parameters, 20 modes.

The model is built from a model-format dictionary (docs/model-format.md) by
``structbench.models.toml_model.structure_from_dict``: 500 Euler-Bernoulli
elements over 50 m (nodes 0..500, node 0 clamped: 1,000 free DOF ``w``,
``theta``), m = 8.4 kg/m, EI = 2e6 N m^2. The 50 parameters are the
stiffnesses of every 10th element (``stiffness[10]``, ..., ``stiffness[500]``);
the truth scales them by ``1 + alpha``, ``alpha`` uniform in (-0.2, 0.2) per
seed. Measured: the 20 lowest modes, shapes at ``w`` of every 10th node (50
DOF), normalised to max entry 1, with ``--noise`` (relative on eigenvalues,
absolute on shape entries, stated as standard errors). One update from the
prior per seed; wall and CPU time (process_time, both cores' threads
counted) per update, medians over the seeds printed. BLAS on one thread,
as ``structbench identify`` runs identifiers (bench/dispatch/parallel.py).

Measured on a clean copy of 83bcbd8, seeds 0-2, run once, load average
10-11 on the 2 cores from other runs: noise-free, median 3.46 s wall
(2.34 s CPU) per update, largest 7.98 s (5.26 s CPU, seed 0), median
|k/k_true - 1| 1.7e-6, rank 50 of 50 (target <= 10 s: met); with 1 %
noise (``--noise 0.01``) median 3.59 s wall (2.48 s CPU), median error
5.4 %, discrepancy rule.

    python benchmarks/updating_scale.py [--seeds 3] [--noise 0.0]
"""
from __future__ import annotations

import argparse
import time

import numpy as np
from threadpoolctl import threadpool_limits

from structbench.identifier.updating import ModalData, update
from structbench.models import Structure
from structbench.models.toml_model import structure_from_dict

ELEMENTS, LENGTH, MASS, EI = 500, 50.0, 8.4, 2e6
PARAMETERS = [f"stiffness[{j}]" for j in range(10, ELEMENTS + 1, 10)]


def beam(scale: dict[int, float] | None = None) -> Structure:
    """The clamped beam; ``scale`` maps element numbers (1-based) to stiffness factors."""
    h = LENGTH / ELEMENTS
    scale = scale or {}
    return structure_from_dict({
        "name": "beam-1000", "unknown": ["stiffness"],
        "nodes": [{"id": i, "x": i * h} for i in range(ELEMENTS + 1)],
        "elements": [{"type": "beam", "nodes": [i, i + 1], "m": MASS, "k": EI / h**3 * scale.get(i + 1, 1.0)}
                     for i in range(ELEMENTS)],
        "supports": [{"node": 0, "type": "clamped"}]})


def measured(truth: Structure, modes: int, noise: float, rng: np.random.Generator) -> ModalData:
    nodes = list(range(10, ELEMENTS + 1, 10))
    found = truth.modes(modes)
    shapes = found.shapes[[truth.dof_index(n, "w") for n in nodes]]
    shapes = shapes / shapes[np.argmax(np.abs(shapes), axis=0), np.arange(modes)]
    lam = found.lam * (1 + noise * rng.standard_normal(modes))
    shapes = shapes + noise * rng.standard_normal(shapes.shape)
    std = noise if noise else np.nan
    return ModalData(lam, np.full(modes, std) * lam, shapes, np.full(shapes.shape, std),
                     [(n, "w") for n in nodes], "beam-1000")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--modes", type=int, default=20)
    parser.add_argument("--noise", type=float, default=0.0)
    args = parser.parse_args()
    threadpool_limits(1, "blas")
    prior = beam()
    walls, cpus, errors = [], [], []
    for seed in range(args.seeds):
        rng = np.random.default_rng(seed)
        alpha = rng.uniform(-0.2, 0.2, len(PARAMETERS))
        truth = beam({j: 1 + a for j, a in zip(range(10, ELEMENTS + 1, 10), alpha)})
        data = measured(truth, args.modes, args.noise, rng)
        w0, c0 = time.perf_counter(), time.process_time()
        result = update(prior, data, parameters=PARAMETERS)
        walls.append(time.perf_counter() - w0)
        cpus.append(time.process_time() - c0)
        got = np.array(result.details["alpha"])
        errors.append(np.median(np.abs((1 + got) / (1 + alpha) - 1)))
        print(f"seed {seed}: {result.status}, {walls[-1]:.2f} s wall, {cpus[-1]:.2f} s CPU, median |k/k_true - 1| "
              f"{errors[-1]:.2e}, rank {result.details['identifiability']['rank']}/{len(PARAMETERS)}, "
              f"{result.details['regularisation']['rule']}")
    print(f"1,000-DOF beam ({prior.n_dof} DOF), {len(PARAMETERS)} parameters, {args.modes} modes, noise {args.noise}: "
          f"median {np.median(walls):.2f} s wall, {np.median(cpus):.2f} s CPU per update; median error "
          f"{np.median(errors):.2e} (seeds 0..{args.seeds - 1})")


if __name__ == "__main__":
    main()
