"""Step-convergence check of an FMU structbench did not build.

An external co-simulation FMU integrates with its own solver at the
communication step (OpenModelica's default: explicit Euler), which may be
far from converged at the sampling interval a test asks for. Before a
campaign on an external FMU (and on demand, ``structbench run CAMPAIGN
--check-step``) the first test's excitation (repetition 0, noise-free) is
simulated twice: as the campaign runs it, and at half the step
(:meth:`.fmu_options.FmuOptions.finer`: substeps doubled; model exchange:
CVode's relative tolerance / 100). Per motion channel x (n,) the difference
``rms(x_h - x_h/2)`` is compared with a tolerance tied to the sensor noise:
the channel's noise sigma (``ratio * rms(x)``), or, noise-free, 1 % of the
response's RMS about its mean. Above it the run's output and ``status.json``
carry a warning naming the test, the channel and the difference. For a
first-order solver the error at the step is about twice that difference.

Costs the first test's simulation once at the campaign's step and once at
half of it (twice the FMU steps; model exchange: a tighter tolerance), on a
worker of the campaign's pool.
"""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import numpy as np

from structbench.models.channels import Channel

from .fmu_setup import Bench, prepare_fmu
from .folder import CampaignStatus, TestStatus
from .noise import rms
from .output_check import SimulationError
from .child import Child, ChildDied, TimedOut
from .pool import LocalPool, Pool, _rig, make_pool
from .simulation import simulate
from .test_entries import TestSpec

NOISE_FREE_SHARE = 0.01  # tolerance of a noise-free channel: this share of its response RMS


def _advice(bench: Bench, factor: float) -> str:
    """What to set: more substeps (first-order estimate) or model exchange."""
    opts = bench.options
    if opts.interface == "model-exchange":
        return f"lower [solver] relative_tolerance (now {opts.relative_tolerance:g})"
    n = opts.substeps * max(2, 2 ** math.ceil(math.log2(max(2 * factor, 1.0))))
    return f"set substeps = {n} (or more) or interface = \"model-exchange\" if the FMU offers it"


def compare(bench: Bench, test: TestSpec, coarse: dict[str, np.ndarray],
            fine: dict[str, np.ndarray]) -> list[dict[str, Any]]:
    """Warnings for the motion channels whose two simulations (name -> (n,))
    differ by more than their tolerance."""
    found = []
    for c in test.channels:
        if c.quantity == "force":
            continue
        x, y = coarse[c.name], fine[c.name]
        ratio = test.noise.ratio(c.quantity)
        tol = ratio * rms(x) if ratio > 0 else NOISE_FREE_SHARE * rms(x - np.mean(x))
        basis = "the noise rms" if ratio > 0 else f"{NOISE_FREE_SHARE:.0%} of the response rms"
        diff = rms(x - y)
        if diff > tol:
            unit = Channel(c.quantity, c.node, c.direction).unit
            found.append({"test": test.name, "channel": c.name, "difference": diff, "tolerance": tol,
                          "unit": unit, "message":
                          f"step check: test {test.name}, {c.name}: the responses at step {test.step:g} s "
                          f"({bench.options.describe()}) and at half of it differ by {diff:.3g} {unit} rms, "
                          f"over {basis} ({tol:.3g} {unit}): the FMU's solver has not converged at this step; "
                          + _advice(bench, diff / tol if tol > 0 else 1e6)})
    return found


def check_task(bench: Bench, test: TestSpec, blob: bytes | None) -> list[dict[str, Any]]:
    """Worker entry point: simulate ``test`` at the campaign's step and at half
    of it and compare; never raises (an FMU failure is a finding of its own)."""
    fine_bench = dataclasses.replace(bench, options=bench.options.finer())
    records = []
    for b, label in ((bench, "the campaign's step"), (fine_bench, "half the step")):
        try:
            records.append(simulate(_rig(b, blob), b, test, 0).signals)
        except SimulationError as err:
            advice = _advice(bench, 1e6) if b is bench else "the FMU may be unstable"
            return [{"test": test.name, "channel": str(err).split(" ", 1)[0], "difference": math.inf,
                     "tolerance": None, "unit": None,
                     "message": f"step check: test {test.name} at {label} ({b.options.describe()}): {err}; {advice}"}]
        except Exception as err:  # noqa: BLE001 - the FMU failed: the test itself will report it
            return [{"test": test.name, "channel": None, "difference": None, "tolerance": None, "unit": None,
                     "message": f"step check: test {test.name} could not be simulated: {type(err).__name__}: {err}"}]
    return compare(bench, test, *records)


def run_step_check(pool: Pool, bench: Bench, test: TestSpec, blob: Any) -> list[dict[str, Any]]:
    """:func:`check_task` on a worker of the local ``pool`` (on Dask: in a
    child process of this one), stopped after 3 x the test's ``timeout``
    (not with ``--jobs 0``); the warnings, or one saying why the check could
    not run."""
    limit = 3 * test.timeout
    why = None
    if isinstance(pool, LocalPool):
        future = pool.submit(check_task, bench, test, blob)
        if not pool.wait([future], limit if pool.can_stop else None):
            pool.restart()
            why = f"timed out after {limit:g} s"
        else:
            try:
                return future.result()
            except Exception:  # noqa: BLE001 - the worker process died
                why = pool.death()
    else:
        child = None
        try:
            child = Child()
            return child.call(check_task, (bench, test, None), limit)
        except TimedOut:
            why = f"timed out after {limit:g} s"
        except ChildDied as err:
            why = str(err)
        finally:
            if child is not None and child.alive:
                child.stop()
    return [{"test": test.name, "channel": None, "difference": None, "tolerance": None, "unit": None,
             "message": f"step check: test {test.name} could not be simulated: {why}"}]


def check_only(campaign: Any, fmu_dir: Path, jobs: int | None, scheduler: str | None) -> CampaignStatus:
    """The step check alone (any FMU; nothing written but a built FMU in
    ``fmu_dir``): a status with every test pending and the findings in
    ``warnings``."""
    bench = prepare_fmu(campaign, fmu_dir)
    pool = make_pool(jobs, scheduler)
    try:
        warnings = run_step_check(pool, bench, campaign.tests[0], pool.share_fmu(Path(bench.fmu)))
    finally:
        pool.close()
    tests = {t.name: TestStatus(t.name, t.group, [t.trace_name(r) for r in range(t.repetitions)])
             for t in campaign.tests}
    status = CampaignStatus(campaign.name, campaign.structure, bench.fmu, bench.fmu_sha256, tests)
    status.warnings = warnings
    return status


__all__ = ["check_only", "check_task", "compare", "run_step_check"]
