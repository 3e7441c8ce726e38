"""Scores of modal results (frequencies, damping ratios, shapes with stated
errors) against the truth, mode by mode.

An output-only identifier may miss modes (no sensor moves, too weak) and
finds them in its own order, so identified modes are paired one-to-one with
the true modes (``linear_sum_assignment`` on the relative frequency
difference plus ``1 - MAC``, pairs only within ``PAIR_TOL`` in frequency and,
where shapes are known, MAC above ``MAC_PAIR``). Every per-mode list is
aligned with the truth's modes; NaN marks a true mode not found (and, for
damping errors, a true damping ratio of 0 or unknown). ``covered`` says
whether the 95 % interval ``value +- 1.96 std`` holds the truth.

Harmonics (``truth["harmonics"]``: per test the periodic forces a
``disturbance`` excitation added, docs/campaign-format.md) are scored by
:func:`harmonic_scores`: a true harmonic is *listed* when an entry of the
run's ``details.harmonics`` lies within ``HARMONIC_TOL`` (relative) or two
spectral lines ``2 (2 pi / T)`` of it (``T``: ``details.record_s``); a
reported mode paired with no true mode and within ``PAIR_HARMONIC`` of a
true harmonic is a *harmonic reported as a mode*; a listed harmonic near no
true one is *spurious*, and a *mode listed as a harmonic* when it is within
``PAIR_HARMONIC`` of a true mode.
"""
from __future__ import annotations

import warnings
from typing import Any

import numpy as np
from scipy.optimize import linear_sum_assignment

from structbench.models.mac import mac

PAIR_TOL = 0.05
MAC_PAIR = 0.5
Z95 = 1.959964
HARMONIC_TOL = 0.002
PAIR_HARMONIC = 0.01


def _sensor_dof(channel: str) -> tuple[int, str]:
    _, node, direction = channel.split("_", 2)
    return int(node), direction


def _mac_table(run: dict[str, Any], truth: dict[str, Any]) -> np.ndarray | None:
    """MAC (n_identified, n_true) when the sensors are in the truth's sensor DOF."""
    if not (run.get("mode_shapes") and truth.get("mode_shapes")):
        return None
    rows = {tuple(d): i for i, d in enumerate(truth["sensor_dofs"])}
    pick = [rows.get(_sensor_dof(c)) for c in run["sensors"]]
    if None in pick:
        return None
    return mac(np.asarray(run["mode_shapes"], dtype=float).T, np.asarray(truth["mode_shapes"], dtype=float)[pick])


def pairs(run: dict[str, Any], truth: dict[str, Any]) -> tuple[np.ndarray, np.ndarray | None]:
    """Index (n_true,) of the identified mode paired with each true mode (-1: none), and the MAC table."""
    est = np.asarray(run.get("omega") or [], dtype=float)
    true = np.asarray(truth.get("omega") or [], dtype=float)
    match = np.full(true.size, -1)
    if not est.size or not true.size:
        return match, None
    table = _mac_table(run, truth)
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.abs(est[:, None] - true[None, :]) / true[None, :]
    ok = rel < PAIR_TOL
    cost = np.where(ok, rel, 1e6)
    if table is not None:
        ok &= table > MAC_PAIR
        cost = np.where(ok, rel + (1 - table), 1e6)
    i, j = linear_sum_assignment(cost)
    keep = ok[i, j]
    match[j[keep]] = i[keep]
    return match, table


def _pick(values: list[float] | None, match: np.ndarray) -> np.ndarray:
    a = np.asarray(values if values else [np.nan] * (match.max() + 1 if match.size else 0), dtype=float)
    return np.where(match >= 0, a[np.maximum(match, 0)] if a.size else np.nan, np.nan)


def modal_scores(run: dict[str, Any], truth: dict[str, Any]) -> dict[str, Any]:
    """Per true mode: identified omega, its error (%), MAC, damping ratio and
    its error (% of the true ratio), and whether the 95 % intervals cover the truth."""
    match, table = pairs(run, truth)
    true = np.asarray(truth.get("omega") or [], dtype=float)
    zeta_true = np.asarray(truth.get("zeta") or [np.nan] * true.size, dtype=float)
    omega, zeta = _pick(run.get("omega"), match), _pick(run.get("damping"), match)
    omega_std, zeta_std = _pick(run.get("omega_std"), match), _pick(run.get("damping_std"), match)
    with np.errstate(divide="ignore", invalid="ignore"):
        freq_err = 100 * (omega - true) / true
        zeta_err = np.where(zeta_true > 0, 100 * (zeta - zeta_true) / zeta_true, np.nan)
    macs = (np.where(match >= 0, table[np.maximum(match, 0), np.arange(true.size)], np.nan)
            if table is not None else None)

    def covered(value: np.ndarray, std: np.ndarray, exact: np.ndarray) -> list[float]:
        ok = np.isfinite(value) & np.isfinite(std) & np.isfinite(exact)
        return np.where(ok, np.abs(value - exact) <= Z95 * std, np.nan).tolist()

    out: dict[str, Any] = {
        "paired": True, "omega": omega.tolist(), "omega_true": true.tolist(), "freq_error_pct": freq_err.tolist(),
        "zeta": zeta.tolist(), "zeta_true": zeta_true.tolist(), "damping_error_pct": zeta_err.tolist(),
        "omega_covered": covered(omega, omega_std, true), "zeta_covered": covered(zeta, zeta_std, zeta_true),
        "extra_modes": int(len(run.get("omega") or []) - np.sum(match >= 0))}
    if macs is not None:
        out["mac"] = macs.tolist()
    if truth.get("harmonics"):
        out["harmonics"] = harmonic_scores(run, true_harmonics(run, truth), truth)
    return out


def true_harmonics(run: dict[str, Any], truth: dict[str, Any]) -> list[dict[str, Any]]:
    """The harmonics (``omega`` rad/s, ...) of the run's tests in ``truth["harmonics"]``
    (test name -> list), each frequency once."""
    table = truth.get("harmonics") or {}
    if isinstance(table, list):
        return table
    seen: dict[float, dict[str, Any]] = {}
    for test in run.get("tests") or []:
        for h in table.get(test, []):
            seen.setdefault(round(float(h["omega"]), 9), h)
    return list(seen.values())


def harmonic_scores(run: dict[str, Any], harmonics: list[dict[str, Any]], truth: dict[str, Any]) -> dict[str, Any]:
    """Harmonics listed and missed, harmonics reported as modes, spurious
    harmonics and modes listed as harmonics (module docstring) of one run
    against ``harmonics`` (each with ``omega`` rad/s)."""
    true_h = np.array([float(h["omega"]) for h in harmonics])
    listed = np.array([float(h["omega"]) for h in (run.get("details") or {}).get("harmonics") or []])
    record = float((run.get("details") or {}).get("record_s") or np.inf)
    tol = np.maximum(HARMONIC_TOL * true_h, 4 * np.pi / record)
    near = np.abs(listed[:, None] - true_h[None, :]) <= tol[None, :] if listed.size and true_h.size \
        else np.zeros((listed.size, true_h.size), bool)
    each = near.any(axis=0)
    match, _ = pairs(run, truth)
    omega = np.asarray(run.get("omega") or [], dtype=float)
    unpaired = np.setdiff1d(np.arange(omega.size), match[match >= 0])
    as_modes = sum(bool(true_h.size) and bool(np.any(np.abs(omega[i] - true_h) <= PAIR_HARMONIC * true_h))
                   for i in unpaired)
    spurious = listed[~near.any(axis=1)] if listed.size else listed
    modes = np.asarray(truth.get("omega") or [], dtype=float)
    modes = modes[modes > 0]
    as_harmonics = sum(bool(modes.size) and bool(np.any(np.abs(w - modes) <= PAIR_HARMONIC * modes))
                       for w in spurious)
    return {"harmonics": int(true_h.size), "listed": int(each.sum()), "missed": int(true_h.size - each.sum()),
            "listed_each": each.tolist(), "as_modes": int(as_modes), "listed_spurious": int(spurious.size),
            "modes_as_harmonics": int(as_harmonics)}


def nanmedian(rows: list[list[float]]) -> list[float]:
    """Column medians ignoring NaN (NaN where a column has no value)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return np.nanmedian(np.asarray(rows, dtype=float), axis=0).tolist()


def nanmean(rows: list[list[float]]) -> list[float]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return np.nanmean(np.asarray(rows, dtype=float), axis=0).tolist()


def modal_summary(runs: list[dict[str, Any]]) -> dict[str, Any]:
    """Over the runs, per true mode: medians of omega, frequency error (%),
    MAC, damping error (%), the share of runs that found the mode, the
    coverage of the 95 % intervals; and the median count of extra modes."""
    out: dict[str, Any] = {
        "omega_median": nanmedian([r["omega"] for r in runs]), "omega_true": runs[0]["omega_true"],
        "freq_error_pct_median": nanmedian([r["freq_error_pct"] for r in runs]),
        "damping_error_pct_median": nanmedian([r["damping_error_pct"] for r in runs]),
        "zeta_median": nanmedian([r["zeta"] for r in runs]), "zeta_true": runs[0]["zeta_true"],
        "found_fraction": np.mean([np.isfinite(r["omega"]) for r in runs], axis=0).tolist(),
        "omega_coverage": nanmean([r["omega_covered"] for r in runs]),
        "zeta_coverage": nanmean([r["zeta_covered"] for r in runs]),
        "extra_modes_median": float(np.median([r["extra_modes"] for r in runs]))}
    if all("mac" in r for r in runs):
        out["mac_median"] = nanmedian([r["mac"] for r in runs])
    if any("harmonics" in r for r in runs):
        scored = [r["harmonics"] for r in runs if "harmonics" in r]
        out["harmonics"] = {key: int(sum(h[key] for h in scored)) for key in
                            ("harmonics", "listed", "missed", "as_modes", "listed_spurious", "modes_as_harmonics")}
    return out
