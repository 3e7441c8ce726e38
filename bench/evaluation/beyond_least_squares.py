""""Beyond the dissertation": the chapter 3 cases identified from every sample
(bias-compensated least squares) beside the dissertation's set-up, and
chapter 4's case 2 by model updating from FRFs, with the coverage of the
stated standard errors.

Coverage of a parameter kind: the fraction of (run, parameter) pairs whose
95 % interval ``value +- 1.96 std_error`` holds the true value, over the
Monte Carlo runs of a results file (calibrated: about 0.95).
"""
from __future__ import annotations

from typing import Any

import numpy as np

# (campaign, results stem) pairs shown, the dissertation's set-up first.
ROWS: tuple[tuple[str, str], ...] = (
    ("ch3", "least-squares-m8"), ("ch3", "least-squares-all"),
    ("ch3", "least-squares-m8-noisy-displacement"), ("ch3", "least-squares-all-noisy-displacement"),
    ("ch3-damped", "least-squares-m8"), ("ch3-damped", "least-squares-all"),
    ("ch4-case2", "updating-case2-frf"),
)
Z95 = 1.959964


def _kinds(labels: list[str]) -> np.ndarray:
    return np.array([label.split("[")[0] for label in labels])


def row(scored: dict[str, Any]) -> dict[str, Any]:
    """Median normalized RMS (p10, p90), per kind the median |relative error|
    (median over runs, worst parameter) and the 95 % coverage; ``efficiency``
    (Cramer-Rao bound / achieved spread, :mod:`efficiency`) when scored."""
    runs = scored["runs"]
    kinds = _kinds(runs[0]["labels"])
    errors = np.abs(np.array([r["errors"] for r in runs]))
    out: dict[str, Any] = {"rms": scored["summary"]["rms"], "runs": len(runs), "kinds": {}}
    if "efficiency" in scored["summary"]:  # the Cramer-Rao bound beside the spread (efficiency.py)
        out["efficiency"] = scored["summary"]["efficiency"]
    z = np.array([r["z"] for r in runs]) if all("z" in r for r in runs) else None
    for kind in dict.fromkeys(kinds.tolist()):
        pick = kinds == kind
        entry = {"median_abs_error": float(np.median(errors[:, pick])),
                 "worst_median_abs_error": float(np.median(errors[:, pick], axis=0).max())}
        if z is not None:
            entry["coverage95"] = float(np.mean(np.abs(z[:, pick]) < Z95))
        out["kinds"][kind] = entry
    return out


def beyond(scores: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """Rows keyed ``campaign/stem`` (see :data:`ROWS`)."""
    return {f"{campaign}/{stem}": row(scores[campaign][stem]) for campaign, stem in ROWS
            if stem in scores.get(campaign, {})}
