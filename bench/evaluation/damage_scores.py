"""Damage detection scores of an updating results file whose prior was a
baseline's identification (``identify --prior BASELINE/results/updating.json``).

Per run and parameter ``j``: the relative change from the prior,
``d_j = p_j / p0_j - 1`` (``p0_j`` the run's ``initial``), and its standard
error ``s_j = sqrt(std_j^2 + std0_j^2) / p0_j`` (``std_j`` the run's
``std_error``, ``std0_j`` the baseline's, from the results' top-level
``prior.std_errors``; without them, or for a stepwise search
(``--option localise=true``, whose errors are scaled by its residual
misfit, which holds the baseline's error), the run's alone). A parameter is
*flagged* when ``|d_j| > Z_FLAG s_j``; a parameter without a standard error
(an undetermined combination) is never flagged.

The truth: the campaign's ``[damage]`` table (``DIR/campaign.toml``):
``stiffness[e]`` of each listed element changed by ``stiffness_factor - 1``,
every other parameter by 0. Per run: ``found`` (every damaged parameter
flagged), ``false`` (flagged parameters not damaged) and the error of each
damaged parameter's change, ``d_j - (factor - 1)``, in percentage points.
"""
from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

import numpy as np

Z_FLAG = 3.0  # flag |change| > 3 standard errors (fixed before any benchmark was run)


def declared_damage(folder: Path) -> dict[str, float] | None:
    """``{label: true relative change}`` of the campaign's ``[damage]`` (None without one)."""
    try:
        table = tomllib.loads((folder / "campaign.toml").read_text(encoding="utf-8")).get("damage")
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return None
    if not isinstance(table, dict) or not table:
        return None
    factor = float(table.get("stiffness_factor", 1.0))
    return {f"stiffness[{int(e)}]": factor - 1.0 for e in table.get("elements", [])}


def damage_run(run: dict[str, Any], prior_std: dict[str, float], declared: dict[str, float] | None,
               z_flag: float = Z_FLAG) -> dict[str, Any]:
    """Changes, their standard errors and the flags of one run (see the module docstring)."""
    params = run.get("parameters") or []
    labels = [p["label"] for p in params]
    value = np.array([p["value"] for p in params], dtype=float)
    initial = np.array([p.get("initial") if p.get("initial") is not None else np.nan for p in params], dtype=float)
    std = np.array([p["std_error"] if p.get("std_error") is not None else np.nan for p in params], dtype=float)
    stepwise = "localisation" in (run.get("details") or {})  # its errors hold the baseline's mismatch already
    std0 = np.array([0.0 if stepwise else prior_std.get(lab, 0.0) for lab in labels], dtype=float)
    change = value / initial - 1.0
    sigma = np.sqrt(std**2 + std0**2) / np.abs(initial)
    z = change / sigma
    flagged = [lab for lab, zz in zip(labels, z) if np.isfinite(zz) and abs(zz) > z_flag]
    out: dict[str, Any] = {"labels": labels, "change": change.tolist(), "change_std": sigma.tolist(),
                           "z": z.tolist(), "flagged": flagged, "z_flag": z_flag}
    if declared is not None:
        index = {lab: i for i, lab in enumerate(labels)}
        out["declared"] = declared
        out["found"] = all(lab in flagged for lab in declared)
        out["false"] = [lab for lab in flagged if lab not in declared]
        out["size_error_pp"] = {lab: 100.0 * (change[index[lab]] - d) if lab in index else None
                                for lab, d in declared.items()}
    return out


def damage_summary(runs: list[dict[str, Any]]) -> dict[str, Any]:
    """Over runs: the share that found every damaged parameter, how often
    each parameter was flagged falsely, and the damaged ones' change (median, pp error)."""
    out: dict[str, Any] = {"runs": len(runs), "z_flag": runs[0]["z_flag"]}
    if "declared" not in runs[0]:
        out["flag_count"] = {}
        for r in runs:
            for lab in r["flagged"]:
                out["flag_count"][lab] = out["flag_count"].get(lab, 0) + 1
        return out
    false: dict[str, int] = {}
    for r in runs:
        for lab in r["false"]:
            false[lab] = false.get(lab, 0) + 1
    errors = {lab: [r["size_error_pp"][lab] for r in runs] for lab in runs[0]["declared"]}
    return out | {"found": int(sum(r["found"] for r in runs)), "false_flag_count": false,
                  "size_error_pp_median": {k: float(np.median(v)) for k, v in errors.items()},
                  "size_error_pp_max_abs": {k: float(np.max(np.abs(v))) for k, v in errors.items()}}


def damage_scores(folder: Path, header: dict[str, Any], runs: list[dict[str, Any]]) -> dict[str, Any] | None:
    """Per-run damage scores and their summary of an updating results file,
    or None when it is not a damage assessment (no baseline prior errors and no ``[damage]``)."""
    prior = header.get("prior") or {}
    declared = declared_damage(folder)
    if header.get("method") != "updating" or (not prior.get("std_errors") and declared is None):
        return None
    scored = [damage_run(r, prior.get("std_errors") or {}, declared) for r in runs]
    return {"runs": scored, "summary": damage_summary(scored)}
