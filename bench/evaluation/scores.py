"""Scoring of a campaign folder: ``results/*.json`` against ``truth.json``.

Per run: normalized RMS parameter error, per-parameter relative errors,
natural-frequency errors (%) and the MAC of mode shapes (modal results with
damping: modes paired with the true ones, damping errors and the coverage of
the stated errors, :mod:`modal_scores`; updating from a baseline: which
parameters changed beyond their errors, :mod:`damage_scores`); per results file a
summary over the Monte Carlo runs (median and 10-90 % spread) and, for least
squares, each parameter's spread beside its Cramer-Rao bound (:mod:`efficiency`).
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from structbench.identifier.io.results import read_results
from structbench.models.errors import UserError

from structbench.models.mac import mac

from .damage_scores import damage_scores
from .efficiency import efficiency, load_folder_campaign
from .metrics import frequency_error_pct, normalized_rms, relative_errors
from .truth_checks import read_truth
from .modal_scores import modal_scores, modal_summary


def load_truth(folder: Path) -> dict[str, Any]:
    path = folder / "truth.json"
    if not path.is_file():
        raise UserError(f"no truth.json in {folder}: nothing to score against", field="CAMPAIGN_DIR")
    return read_truth(path)


def _truth_values(truth: dict[str, Any], labels: list[str]) -> np.ndarray:
    table = {p["label"]: p["value"] for p in truth.get("parameters", [])}
    missing = [label for label in labels if label not in table]
    if missing:
        raise UserError(f"parameters {missing[:5]} are not in truth.json", field="parameters")
    return np.array([table[label] for label in labels], dtype=float)


def _sensor_dof(channel: str) -> tuple[int, str]:
    _, node, direction = channel.split("_", 2)
    return int(node), direction


def _mode_scores(run: dict[str, Any], truth: dict[str, Any]) -> dict[str, Any]:
    if run.get("damping"):  # modal results: modes paired with the truth's (modal_scores.py)
        return modal_scores(run, truth)
    omega = np.asarray(run.get("omega") or [], dtype=float)
    true_omega = np.asarray(truth.get("omega") or [], dtype=float)
    n = min(omega.size, true_omega.size)
    out: dict[str, Any] = {"omega": omega[:n].tolist(), "omega_true": true_omega[:n].tolist(),
                           "freq_error_pct": frequency_error_pct(omega[:n], true_omega[:n]).tolist()}
    shapes = run.get("mode_shapes") or []
    if shapes and truth.get("mode_shapes"):
        rows = {tuple(d): i for i, d in enumerate(truth["sensor_dofs"])}
        pick = [rows.get(_sensor_dof(c)) for c in run["sensors"]]
        if None not in pick:
            true_shapes = np.asarray(truth["mode_shapes"], dtype=float)[pick]
            m = min(len(shapes), true_shapes.shape[1], n)
            ident = np.asarray(shapes, dtype=float)[:m].T
            out["mac"] = np.diag(mac(ident, true_shapes[:, :m])).tolist()
    return out


def score_run(run: dict[str, Any], truth: dict[str, Any]) -> dict[str, Any]:
    """Scores of one run (a dict of docs/results-format.md)."""
    out: dict[str, Any] = {"repetition": run["repetition"], "status": run["status"]}
    params = run.get("parameters") or []
    if params:
        labels = [p["label"] for p in params]
        true = _truth_values(truth, labels)
        est = np.array([p["value"] for p in params], dtype=float)
        out |= {"rms": normalized_rms(est, true), "labels": labels,
                "errors": relative_errors(est, true).tolist()}
        if all(p.get("std_error") for p in params):  # standardized errors, for coverage of the stated errors
            out["z"] = ((est - true) / np.array([p["std_error"] for p in params], dtype=float)).tolist()
        if run.get("history"):
            out["rms_history"] = [normalized_rms(np.asarray(row, dtype=float), true) for row in run["history"]]
            out["rms_initial"] = out["rms_history"][0]
            out["iterations"] = run.get("iterations")
    return out | _mode_scores(run, truth)


def _spread(values: list[float]) -> dict[str, float]:
    a = np.asarray(values, dtype=float)
    return {"median": float(np.median(a)), "p10": float(np.percentile(a, 10)),
            "p90": float(np.percentile(a, 90))}


def summarize(runs: list[dict[str, Any]]) -> dict[str, Any]:
    """Medians and spreads over the runs of one results file."""
    out: dict[str, Any] = {"runs": len(runs)}
    if "rms" in runs[0]:
        out["rms"] = _spread([r["rms"] for r in runs])
        out["errors_median"] = dict(zip(runs[0]["labels"],
                                        np.median([r["errors"] for r in runs], axis=0).tolist()))
    if "rms_initial" in runs[0]:
        out["rms_initial"] = _spread([r["rms_initial"] for r in runs])
        out["improved_fraction"] = float(np.mean([r["rms"] < r["rms_initial"] for r in runs]))
        out["iterations"] = [r["iterations"] for r in runs]
    if runs[0].get("paired"):
        return out | modal_summary(runs)
    n = min(len(r["freq_error_pct"]) for r in runs)
    if n:
        out["omega_median"] = np.median([r["omega"][:n] for r in runs], axis=0).tolist()
        out["omega_true"] = runs[0]["omega_true"][:n]
        out["freq_error_pct_median"] = np.median([r["freq_error_pct"][:n] for r in runs], axis=0).tolist()
    if all("mac" in r for r in runs):
        k = min(len(r["mac"]) for r in runs)
        out["mac_median"] = np.median([r["mac"][:k] for r in runs], axis=0).tolist()
    return out


def score_campaign(folder: str | Path) -> dict[str, Any]:
    """Score every ``results/*.json`` of a campaign folder; keyed by file stem."""
    folder = Path(folder)
    truth = load_truth(folder)
    files = sorted((folder / "results").glob("*.json"))
    if not files:
        raise UserError(f"no results in {folder / 'results'}: run structbench identify first", field="CAMPAIGN_DIR")
    scores = {}
    loaded: list[Any] = []  # the folder's campaign, loaded once for the bounds (efficiency.py)

    def campaign() -> Any:
        if not loaded:
            loaded.append(load_folder_campaign(folder))
        return loaded[0]

    for path in files:
        header, runs = read_results(path)
        if not runs:
            raise UserError("holds no runs: nothing to score", field=path.name)
        plain = [r.to_dict() for r in runs]
        scored = [score_run(r, truth) for r in plain]
        scores[path.stem] = {"method": header["method"], "summary": summarize(scored), "runs": scored}
        bound = efficiency(folder, header, plain, campaign)  # least squares: achieved spread / Cramer-Rao bound
        if bound is not None:
            scores[path.stem]["summary"]["efficiency"] = bound
        damage = damage_scores(folder, header, plain)  # updating from a baseline: what changed
        if damage is not None:
            scores[path.stem]["damage"] = damage
    return scores
