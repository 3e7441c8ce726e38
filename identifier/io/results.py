"""Identification results and their JSON file (``docs/results-format.md``).

One :class:`Identification` per repetition; :func:`write_results` puts the runs
of one method into ``CAMPAIGN_DIR/results/<method>[-<tag>].json``.
"""
from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

import numpy as np

from .json_checks import load_json
from .result_checks import check_results

FORMAT = "structbench-result"
FORMAT_VERSION = 1


@dataclass
class ParameterEstimate:
    """One identified parameter: ``label`` as ``kind[element]`` (1-based), its
    SI ``unit``, ``value``, standard error (None when not estimated) and the
    starting value of an iterative method."""

    label: str
    kind: str
    unit: str
    value: float
    std_error: float | None = None
    initial: float | None = None


@dataclass
class Identification:
    """The result of one method on one repetition.

    Parametric methods fill ``parameters`` (only the identified, unknown
    kinds); the perturbation method also ``iterations``, ``history`` (parameter
    values per iteration, row 0 the starting values, same order as
    ``parameters``) and ``misfit_history``; the Rayleigh method fills ``omega``
    (rad/s), ``eigenvalues`` (omega^2, rad^2/s^2), ``mode_shapes`` (one list per
    mode over ``sensors``). The modal method also fills ``damping`` (damping
    ratios), ``omega_std`` (rad/s) and ``damping_std`` (standard errors, NaN
    where not estimated), ``mpc`` (modal phase collinearity, 1 = real mode)
    and ``mode_shapes_complex`` (per mode, per sensor ``[re, im]``, unit norm),
    ``mode_shapes_std`` (per mode over ``sensors``: standard errors of the
    ``mode_shapes`` entries, their scale fitted; NaN where not estimated).
    ``details`` holds method-specific diagnostics.
    """

    method: str
    structure: str
    repetition: int
    tests: list[str]
    status: str = "ok"
    message: str = ""
    parameters: list[ParameterEstimate] = field(default_factory=list)
    iterations: int | None = None
    history: list[list[float]] = field(default_factory=list)
    misfit_history: list[float] = field(default_factory=list)
    omega: list[float] = field(default_factory=list)
    eigenvalues: list[float] = field(default_factory=list)
    mode_shapes: list[list[float]] = field(default_factory=list)
    sensors: list[str] = field(default_factory=list)
    damping: list[float] = field(default_factory=list)
    omega_std: list[float] = field(default_factory=list)
    damping_std: list[float] = field(default_factory=list)
    mpc: list[float] = field(default_factory=list)
    mode_shapes_complex: list[list[list[float]]] = field(default_factory=list)
    mode_shapes_std: list[list[float]] = field(default_factory=list)
    details: dict[str, Any] = field(default_factory=dict)

    def values(self) -> np.ndarray:
        """Identified parameter values, shape (n_par,)."""
        return np.array([p.value for p in self.parameters])

    def labels(self) -> list[str]:
        return [p.label for p in self.parameters]

    def to_dict(self) -> dict[str, Any]:
        return _plain(asdict(self))

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> "Identification":
        data = dict(data)
        data["parameters"] = [ParameterEstimate(**p) for p in data.get("parameters", [])]
        return cls(**data)


def _plain(obj: Any) -> Any:
    """JSON-ready copy: numpy scalars and arrays become Python numbers and lists."""
    if isinstance(obj, dict):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _plain(obj.tolist())
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


def software() -> str:
    try:
        return f"structbench {version('structbench')}"
    except PackageNotFoundError:
        return "structbench unknown"


def results_document(method: str, runs: list[Identification], campaign: str, model: str,
                     options: dict[str, Any]) -> dict[str, Any]:
    """The whole result file as a dict."""
    return {"format": FORMAT, "format_version": FORMAT_VERSION, "method": method, "campaign": campaign,
            "structure": runs[0].structure if runs else "", "model": model, "software": software(),
            "options": _plain(options), "runs": [r.to_dict() for r in runs]}


def result_path(campaign_dir: str | Path, method: str, tag: str | None = None) -> Path:
    """``CAMPAIGN_DIR/results/<method>[-<tag>].json``."""
    return Path(campaign_dir) / "results" / (f"{method}-{tag}.json" if tag else f"{method}.json")


def write_results(path: str | Path, document: dict[str, Any]) -> Path:
    """Write a result document (creating ``results/``); returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(json.dumps(document, indent=1, allow_nan=True) + "\n")
    tmp.replace(path)
    return path


def read_results(path: str | Path) -> tuple[dict[str, Any], list[Identification]]:
    """A result file: its header (everything but ``runs``) and the runs;
    a :class:`~.json_checks.JsonError` naming the key if it is not valid."""
    data = load_json(Path(path))
    check_results(Path(path), data, FORMAT)
    runs = [Identification.from_dict(r) for r in data.pop("runs")]
    return data, runs
