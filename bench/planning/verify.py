"""``--verify N``: the planned test run N times through the FMU and the
method, predicted standard errors against the achieved spread.

The campaign's chosen test alone (``campaign_files.test_campaign``) with
``repetitions = N`` and an explicit seed runs through
:func:`structbench.run_campaign` (FMU, sensor noise per repetition) into a
folder, :func:`structbench.identify` identifies every repetition, and per
quantity the sample standard deviation over the N runs (``ddof = 1``; its
own relative standard error about ``1 / sqrt(2 (N - 1))``) is compared with
the prediction (``updating``: the modes of every repetition from
``modal``, then ``updating`` from them, starting from the campaign's
``[prior]`` if it has one, else from the planning model, unregularised:
the spread, not the convergence from a wrong start, is what is checked). Modes are
matched to the planned ones by the nearest identified ``omega`` within
:data:`MATCH` (relative); a mode found in fewer than 3 runs gets no
achieved value (None).
"""
from __future__ import annotations

import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .campaign_files import test_campaign

MATCH = 0.03


def _std(values: Sequence[float]) -> float | None:
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    return float(np.std(v, ddof=1)) if v.size >= 3 else None


def _ratio(achieved: float | None, predicted: float) -> float | None:
    return achieved / predicted if achieved is not None and predicted > 0 else None


def compare(document: dict[str, Any], runs: list[dict[str, Any]]) -> dict[str, Any]:
    """Rows ``{label, predicted_std, achieved_std, ratio, runs}`` for the
    parameters and ``{omega, predicted_*_std, achieved_*_std, ...}`` for the
    modes of the plan ``document`` against the identified ``runs``; ``median_ratio``
    over every quantity (achieved / predicted)."""
    params = []
    for p in document.get("parameters", []):
        values = [q["value"] for r in runs for q in r.get("parameters", []) if q["label"] == p["label"]]
        achieved = _std(values)
        params.append({"label": p["label"], "predicted_std": p["predicted_std"], "achieved_std": achieved,
                       "ratio": _ratio(achieved, p["predicted_std"]), "mean": float(np.mean(values))
                       if values else None, "runs": len(values)})
    modes = []
    for m in document.get("modes", []):
        om, ze = [], []
        for r in runs:
            omega = np.asarray(r.get("omega", []), dtype=float)
            if omega.size == 0:
                continue
            i = int(np.argmin(np.abs(omega - m["omega"])))
            if abs(omega[i] - m["omega"]) <= MATCH * m["omega"]:
                om.append(omega[i])
                damping = r.get("damping") or []
                ze.append(damping[i] if i < len(damping) else np.nan)
        a_om, a_ze = _std(om), _std(ze)
        modes.append({"omega": m["omega"], "predicted_omega_std": m["predicted_omega_std"],
                      "achieved_omega_std": a_om, "omega_ratio": _ratio(a_om, m["predicted_omega_std"]),
                      "zeta": m["zeta"], "predicted_zeta_std": m["predicted_zeta_std"],
                      "achieved_zeta_std": a_ze, "zeta_ratio": _ratio(a_ze, m["predicted_zeta_std"]),
                      "runs": len(om)})
    ratios = [p["ratio"] for p in params] + [m[k] for m in modes for k in ("omega_ratio", "zeta_ratio")]
    ratios = [r for r in ratios if r is not None]
    return {"parameters": params, "modes": modes, "runs": len(runs),
            "median_ratio": float(np.median(ratios)) if ratios else None}


def _updating(api, folder: Path, file: Path, test: str, model: str | Path | None, jobs: int | None,
              options: dict[str, Any]) -> dict[str, Any]:
    """Modes of every repetition (``modal``), then ``updating`` from them,
    starting from the campaign's ``[prior]``, else from the planning model,
    without regularisation unless ``options`` say otherwise: the bound is
    that of unbiased estimators, and Tikhonov toward a prior at the
    planning model (the truth of these runs) pulls the spread below it."""
    import tomllib
    options = {"regularisation": "none"} | options
    api.identify(folder, "modal", model=model, groups=[test], jobs=jobs)
    prior = None
    if not (folder / "prior.json").is_file():
        prior = model if model is not None else tomllib.loads(file.read_text(encoding="utf-8"))["structure"]
    return api.identify(folder, "updating", model=model, groups=[test], jobs=jobs, prior=prior, **options)


def verify(campaign: str | Path, test: str, method: str, repetitions: int, document: dict[str, Any],
           model: str | Path | None = None, seed: int = 0, out: str | Path | None = None,
           jobs: int | None = None, progress: Callable[[str], None] | None = None,
           **options: Any) -> dict[str, Any]:
    """Run ``repetitions`` of ``test`` (seed ``seed``) and identify them with
    ``method`` (``options`` as for :func:`structbench.identify`); returns
    :func:`compare` of the plan ``document`` with them, plus ``seed`` and
    ``folder`` (``out``, default a temporary folder that is removed)."""
    from structbench import api
    say = progress or (lambda line: None)
    with tempfile.TemporaryDirectory(prefix="structbench-plan-") as tmp:
        folder = Path(out) if out is not None else Path(tmp) / "verify"
        folder.mkdir(parents=True, exist_ok=True)
        file = folder.parent / f"{folder.name}-campaign.toml"
        file.write_text(test_campaign(campaign, test, repetitions=repetitions, seed=seed), encoding="utf-8")
        say(f"verify: {repetitions} repetitions of {test!r} through the FMU into {folder}")
        status = api.run_campaign(file, folder, jobs=jobs)
        if status.failed:
            raise api.UserError(f"--verify: {status.failed} test(s) failed in {folder}/status.json", field="--verify")
        say(f"verify: identifying with {method}")
        if method == "updating":
            doc = _updating(api, folder, file, test, model, jobs, options)
        else:
            doc = api.identify(folder, method, model=model, groups=[test], jobs=jobs, **options)
        result = compare(document, doc["runs"])
    return result | {"seed": seed, "repetitions": repetitions, "folder": str(out) if out is not None else None}
