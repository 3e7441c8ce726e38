"""Accuracy gates: thresholds of a campaign's ``[check]`` table against its scores.

Keys (all optional): ``rms_max`` and ``rms_p90_max`` (normalized RMS parameter
error, median and 90th percentile over runs), ``freq_error_pct_max`` (largest
absolute median frequency error, %), ``mac_min`` (smallest median MAC),
``improved_fraction_min`` (share of runs better than the starting model),
``damping_error_pct_max`` (largest absolute median damping-ratio error, % of
the true ratio), ``coverage_min`` and ``coverage_max`` (the share of runs
whose 95 % intervals of frequency and damping hold the truth, smallest and
largest over the modes) and ``modes`` (1-based modes the frequency and MAC gates look at; default all).
Top-level keys apply to every results file; a sub-table ``[check.<results
file stem>]`` (e.g. ``[check.rayleigh]``) overrides them for that file.
"""
from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from structbench.models.errors import UserError

from .scores import score_campaign

GATES = {"rms_max", "rms_p90_max", "freq_error_pct_max", "mac_min", "improved_fraction_min", "modes",
         "damping_error_pct_max", "coverage_min", "coverage_max"}


def _modes(values: list[float], modes: list[int] | None) -> np.ndarray:
    a = np.asarray(values, dtype=float)
    return a if modes is None else a[[m - 1 for m in modes if m - 1 < a.size]]


def _measures(summary: dict[str, Any], modes: list[int] | None) -> dict[str, float]:
    out: dict[str, float] = {}
    if "rms" in summary:
        out["rms_max"] = summary["rms"]["median"]
        out["rms_p90_max"] = summary["rms"]["p90"]
    if "improved_fraction" in summary:
        out["improved_fraction_min"] = summary["improved_fraction"]
    if summary.get("freq_error_pct_median"):
        out["freq_error_pct_max"] = float(np.abs(_modes(summary["freq_error_pct_median"], modes)).max())
    if summary.get("mac_median"):
        out["mac_min"] = float(_modes(summary["mac_median"], modes).min())
    if summary.get("damping_error_pct_median"):
        out["damping_error_pct_max"] = float(np.abs(_modes(summary["damping_error_pct_median"], modes)).max())
    if summary.get("omega_coverage"):
        both = np.concatenate([_modes(summary["omega_coverage"], modes), _modes(summary["zeta_coverage"], modes)])
        out["coverage_min"] = float(both.min())
        out["coverage_max"] = float(both.max())
    return out


def gates_for(check: Mapping[str, Any], stem: str) -> dict[str, Any]:
    """The thresholds that apply to one results file."""
    flat = {k: v for k, v in check.items() if not isinstance(v, Mapping)}
    own = check.get(stem, {})
    gates = flat | dict(own)
    unknown = sorted(set(gates) - GATES)
    if unknown:
        raise UserError(f"unknown gate(s) {unknown}; known: {sorted(GATES)}", field="check")
    for gate, value in gates.items():
        if gate == "modes":
            if not isinstance(value, list) or not all(type(m) is int and m >= 1 for m in value):
                raise UserError(f"expected a list of mode numbers >= 1, got {value!r:.60}", field="check.modes")
        elif isinstance(value, bool) or not isinstance(value, (int, float)):
            raise UserError(f"expected a number, got {value!r:.60}", field=f"check.{gate}")
    return gates


def evaluate(check: Mapping[str, Any], scores: dict[str, Any]) -> list[dict[str, Any]]:
    """One row per (results file, gate): measured value, threshold, pass."""
    rows = []
    for stem, score in scores.items():
        gates = gates_for(check, stem)
        measured = _measures(score["summary"], gates.get("modes"))
        for gate, threshold in gates.items():
            if gate == "modes" or gate not in measured:
                continue
            value = measured[gate]
            ok = value >= threshold if gate.endswith("_min") else value <= threshold
            rows.append({"results": stem, "gate": gate, "value": value, "threshold": threshold, "ok": bool(ok)})
    return rows


def check_campaign(folder: str | Path, results: Sequence[str] | None = None) -> list[dict[str, Any]]:
    """Gate a campaign folder: its ``campaign.toml``'s ``[check]`` table
    against the scores of its results (:func:`evaluate` rows, each also
    naming the ``campaign``); ``results``: only these results file stems
    (e.g. ``["peaks-ci"]``), each of which must exist."""
    folder = Path(folder)
    copy = folder / "campaign.toml"
    if not copy.is_file():
        raise UserError(f"no campaign.toml in {folder}", field="CAMPAIGN_DIR")
    try:
        document = tomllib.loads(copy.read_text())
        check = document.get("check", {})
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as err:
        raise UserError(f"not a readable campaign file: {err}", field=str(copy)) from None
    if not isinstance(check, dict):
        raise UserError(f"expected a table, got {check!r:.60}", field="check")
    if not check:
        raise UserError("the campaign file has no [check] table: nothing to gate on", field="check")
    scores = score_campaign(folder)
    if results is not None:
        missing = sorted(set(results) - set(scores))
        if missing:
            raise UserError(f"no results file {missing[0]}.json in {folder / 'results'}", field="results")
        scores = {stem: scores[stem] for stem in results}
    rows = evaluate(check, scores)
    if not rows:
        which = f" {', '.join(results)}" if results is not None else " present"
        raise UserError(f"no [check] threshold applies to the results{which}", field="check")
    name = str(document.get("name", folder.name))
    return [{"campaign": name} | row for row in rows]
