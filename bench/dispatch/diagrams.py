"""Stabilisation diagrams of the modal method: one PNG per run beside the
results file, ``results/<stem>-stabilisation-<run>.png`` (matplotlib, Agg).

Every pole of every model order is drawn at (frequency rad/s, order): grey
when unstable, blue when stable (:mod:`structbench.identifier.modal.stabilisation`);
the selected modes are the vertical lines.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def diagram(path: Path, run: dict[str, Any], title: str) -> Path:
    """Draw one run's stabilisation diagram (``details["stabilisation"]``) into ``path``."""
    data = run["details"]["stabilisation"]
    order, omega = np.asarray(data["order"]), np.asarray(data["omega"])
    stable = np.asarray(data["stable"], dtype=bool)
    fig, ax = plt.subplots(figsize=(8, 4.5))
    ax.plot(omega[~stable], order[~stable], ".", ms=3, color="0.7", label="pole")
    ax.plot(omega[stable], order[stable], "o", ms=3, mfc="none", color="C0", label="stable pole")
    for i, w in enumerate(run["omega"]):
        ax.axvline(w, color="C3", lw=0.8, alpha=0.7, label="selected mode" if i == 0 else None)
    top = max(run["omega"], default=1.0) * 1.3
    ax.set_xlim(0, top)
    ax.set_xlabel("natural frequency omega (rad/s)")
    ax.set_ylabel("model order")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=8, loc="lower right")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def write_diagrams(document: dict[str, Any], results_path: Path, runs: int | None = None) -> list[Path]:
    """One diagram per run of a result document that has stabilisation data (of
    the first ``runs`` runs only, when given: about 0.09 CPU s each)."""
    out = []
    for i, run in enumerate(document["runs"][:runs]):
        if "stabilisation" in run.get("details", {}):
            path = results_path.with_name(f"{results_path.stem}-stabilisation-{i:02d}.png")
            out.append(diagram(path, run, f"{results_path.stem}: repetition {run['repetition']}, "
                                          f"{', '.join(run['tests'])}"))
    return out
