"""The bound beside every figure: the achieved spread of each least-squares
or updating parameter over the Monte Carlo runs of a results file against
its Cramer-Rao bound (``structbench plan``: :mod:`structbench.planning.fisher`
for least squares, :mod:`structbench.planning.updating` for updating from
the modes of one free-decay test).

Per parameter ``achieved_std`` is the sample standard deviation (ddof 1)
of the estimates over the runs (SI units), ``bound_std`` the square root of
the diagonal of the predicted covariance, computed from the campaign's own
true model (``campaign.toml`` of the folder with its ``[parameters]``) on
the noise-free, exactly (zero-order hold) simulated responses of the same
tests, at the same sample times (``options.samples``, ``interval``), and

    efficiency = bound_std / achieved_std     (1 at best, < 1 above the bound).

The bound is that of the default estimator (bias-compensated, whitened by
the sensor noise, measured displacements and velocities): a results file
run with ``ols``, another weighting or integrated motion is compared with
it all the same, and ``same_settings`` is false (``bound`` says which).
With a random force drawn anew per repetition the bound is the mean of the
predicted variances of up to :data:`MAX_REALISATIONS` of the runs'
realisations (law of total variance).

Only for ``least-squares`` and ``updating`` results with at least :data:`MIN_RUNS` runs of
one set of tests (the set with the most runs when a file holds several);
the sample deviation of N runs is itself uncertain by about
``1 / sqrt(2 (N - 1))``. When no bound can be computed (an external FMU,
a model file not found, a DOF without an acceleration, velocity or
displacement channel) ``reason`` says why and there are no parameters.
"""
from __future__ import annotations

import tempfile
import tomllib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from structbench.models.errors import UserError

MIN_RUNS = 5
UPDATING = ("Cramer-Rao bound of updating from the free decay's frequencies and mode shapes (structbench plan "
            "--method updating)")
MAX_REALISATIONS = 5
DEFAULT = {"estimator": "bias-compensated", "samples": None, "integration": "auto", "weighting": "noise"}


def load_folder_campaign(folder: Path):
    """The campaign of a folder's ``campaign.toml`` copy. A relative model
    path (relative to the original campaign file, which the copy does not
    record) is looked for beside the folder, in the working folder and in
    the folder, as ``identify`` does; raises :class:`UserError` if none loads."""
    from structbench.harness.campaign import load_campaign
    from structbench.planning.campaign_files import dumps
    copy = folder / "campaign.toml"
    if not copy.is_file():
        raise UserError(f"no campaign.toml in {folder}", field="CAMPAIGN_DIR")
    try:
        return load_campaign(copy)
    except UserError as err:
        first = err
    data = tomllib.loads(copy.read_text(encoding="utf-8"))
    ref = data.get("structure")
    if not isinstance(ref, str) or not ref.endswith(".toml"):
        raise first
    with tempfile.TemporaryDirectory(prefix="structbench-score-") as tmp:
        for base in (folder.parent, Path.cwd(), folder):
            candidate = (base / ref).resolve()
            if not candidate.is_file():
                continue
            path = Path(tmp) / "campaign.toml"
            path.write_text(dumps(data | {"structure": str(candidate)}), encoding="utf-8")
            try:
                return load_campaign(path)
            except UserError:
                continue
    raise first


def _motion(model, spec, repetition: int, options: dict[str, Any]):
    """Noise-free :class:`Motion` of one test at the results' sample times."""
    from structbench.identifier.least_squares import Motion, sample_indices
    from structbench.planning.fisher import motion
    from structbench.planning.response import simulate_test
    full = motion(model, simulate_test(model, spec, repetition))
    if options.get("samples") is None:
        return full
    idx = sample_indices(full.times, int(options["samples"]), float(options.get("interval") or 0.5), spec.name)
    return Motion(full.times[idx], full.displacement[idx], full.velocity[idx], full.acceleration[idx],
                  full.force[idx], {q: s[idx] for q, s in full.sigma.items()})


def bound(campaign, tests: list[str], repetitions: list[int],
          options: dict[str, Any]) -> tuple[list[str], np.ndarray, int]:
    """Labels, bound standard deviations (q,) SI and the number of excitation
    realisations averaged, for the runs of ``tests`` (names) at
    ``repetitions``; raises :class:`UserError` when it cannot be computed."""
    from structbench.models import Structure
    from structbench.planning.fisher import least_squares_covariance
    model = campaign.true_model
    if not isinstance(model, Structure):
        raise UserError("no finite-element model to compute the bound with (external FMU or modal model)",
                        field="structure")
    specs = [t for t in campaign.tests if t.name in tests]
    if len(specs) != len(set(tests)):
        raise UserError(f"tests {sorted(set(tests) - {t.name for t in specs})} are not in campaign.toml",
                        field="tests")
    varies = any(s.simulates_each_repetition for s in specs)
    reps = sorted(set(repetitions))
    picked = [reps[i] for i in np.unique(np.linspace(0, len(reps) - 1, MAX_REALISATIONS).round().astype(int))] \
        if varies else reps[:1]
    variances = []
    for rep in picked:
        labels, cov = least_squares_covariance(model, [_motion(model, s, rep, options) for s in specs])
        variances.append(np.diag(cov))
    return labels, np.sqrt(np.mean(variances, axis=0)), len(picked)


def updating_bound(campaign, tests: list[str]) -> tuple[list[str], np.ndarray, int]:
    """Labels and bound standard deviations (q,) SI (NaN: undetermined) of
    updating from the modes of one free-decay test (:mod:`structbench.planning.updating`)."""
    from structbench.planning.updating import updating_bounds
    specs = [t for t in campaign.tests if t.name in tests]
    if len(specs) != 1:
        raise UserError(f"the updating bound is for the modes of one free-decay test, these runs used {tests}",
                        field="tests")
    planned = updating_bounds(campaign.true_model, specs[0])["parameters"]
    std = np.array([np.nan if p["predicted_std"] is None else p["predicted_std"] for p in planned])
    return [p["label"] for p in planned], std, 1


def _describe(options: dict[str, Any], details: dict[str, Any]) -> tuple[str, bool]:
    """What the bound is, and whether the results used the estimator it bounds."""
    used = {k: options.get(k, v) for k, v in DEFAULT.items()}
    differs = [f"{k} {used[k]}" for k, v in DEFAULT.items() if used[k] != v and k != "samples"]
    if details.get("motion") not in (None, ["measured"]) and used["integration"] == "auto":
        differs.append(f"motion {'/'.join(details['motion'])}")
    where = ("every sample" if used["samples"] is None
             else f"the same {used['samples']} samples per trace (interval {options.get('interval')} s)")
    text = (f"Cramer-Rao bound of the default estimator (bias-compensated, noise-whitened, measured motion) on "
            f"{where}")
    if differs:
        return text + f"; these results used {', '.join(differs)}: not the estimator the bound is for", False
    return text + ": the estimator these results used", True


def _finite(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


def efficiency(folder: Path, header: dict[str, Any], runs: list[dict[str, Any]],
               load: Callable[[], Any] | None = None) -> dict[str, Any] | None:
    """``summary.efficiency`` of one results file (module docstring), or None
    (not least squares, fewer than :data:`MIN_RUNS` runs of one set of tests).
    ``load``: returns the folder's campaign (default :func:`load_folder_campaign`;
    a caller scoring several files passes one that loads it once)."""
    method = header.get("method")
    if method not in ("least-squares", "updating"):
        return None
    sets: dict[tuple[str, ...], list[dict[str, Any]]] = {}
    for r in runs:
        if r.get("parameters"):
            sets.setdefault(tuple(r.get("tests") or []), []).append(r)
    if not sets:
        return None
    tests, chosen = max(sets.items(), key=lambda kv: len(kv[1]))
    if len(chosen) < MIN_RUNS:
        return None
    options = header.get("options") or {}
    text, same = _describe(options, chosen[0].get("details") or {}) if method == "least-squares" else (UPDATING, True)
    out: dict[str, Any] = {"tests": list(tests), "runs": len(chosen), "bound": text, "same_settings": same}
    try:
        campaign = load() if load is not None else load_folder_campaign(folder)
        if method == "least-squares":
            labels, std, realisations = bound(campaign, list(tests), [int(r["repetition"]) for r in chosen], options)
        else:
            labels, std, realisations = updating_bound(campaign, list(tests))
    except UserError as err:
        return out | {"reason": f"no bound: {err}", "parameters": []}
    table = {lab: s for lab, s in zip(labels, std)}
    names = [p["label"] for p in chosen[0]["parameters"] if p["label"] in table]
    values = np.array([[{p["label"]: p["value"] for p in r["parameters"]}.get(lab, np.nan) for lab in names]
                       for r in chosen], dtype=float)
    ok = np.all(np.isfinite(values), axis=1)
    if ok.sum() < MIN_RUNS:
        return out | {"reason": f"fewer than {MIN_RUNS} runs with finite estimates", "parameters": []}
    achieved = np.std(values[ok], axis=0, ddof=1)
    bounds = np.array([table[lab] for lab in names])
    with np.errstate(divide="ignore", invalid="ignore"):
        eff = np.where(achieved > 0, bounds / achieved, np.nan)
    rows = [{"label": lab, "achieved_std": float(a), "bound_std": _finite(b), "efficiency": _finite(e)}
            for lab, a, b, e in zip(names, achieved, bounds, eff)]
    finite = eff[np.isfinite(eff)]
    stats = ({"median": float(np.median(finite)), "p10": float(np.percentile(finite, 10)),
              "p90": float(np.percentile(finite, 90)), "min": float(finite.min()), "max": float(finite.max())}
             if finite.size else {"median": None})
    return out | {"runs": int(ok.sum()), "realisations": realisations, **stats, "parameters": rows}
