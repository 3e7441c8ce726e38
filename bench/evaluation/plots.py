"""Report figures (matplotlib, Agg backend, PNG files)."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def _save(fig: plt.Figure, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def parameter_distribution(path: Path, title: str, truth: dict[str, np.ndarray],
                           estimates: dict[str, np.ndarray], units: dict[str, str]) -> Path:
    """Identified vs true element parameters, one panel per kind.

    ``truth[kind]`` has shape (n_el,); ``estimates[kind]`` (n_rep, n_el):
    the median is drawn with a 10-90 % band over repetitions.
    """
    kinds = list(truth)
    fig, axes = plt.subplots(len(kinds), 1, figsize=(7, 2.6 * len(kinds)), squeeze=False)
    for ax, kind in zip(axes[:, 0], kinds):
        element = np.arange(1, truth[kind].size + 1)
        est = np.atleast_2d(estimates[kind])
        ax.step(element, truth[kind], where="mid", color="k", label="true")
        ax.plot(element, np.median(est, axis=0), "o", color="C0", label="identified (median)")
        if est.shape[0] > 1:
            lo, hi = np.percentile(est, [10, 90], axis=0)
            ax.vlines(element, lo, hi, color="C0", alpha=0.6, label="10-90 %")
        ax.set_xlabel("element")
        ax.set_ylabel(f"{kind} ({units.get(kind, '')})")
        ax.legend(fontsize=8)
    axes[0, 0].set_title(title)
    return _save(fig, path)


def rms_history(path: Path, title: str, histories: dict[str, np.ndarray]) -> Path:
    """Normalized RMS parameter error vs iteration (like Figures 4.2-4.5);
    each entry is (n_iter + 1,) or (n_rep, n_iter + 1)."""
    fig, ax = plt.subplots(figsize=(6, 3.6))
    for i, (label, hist) in enumerate(histories.items()):
        hist = np.atleast_2d(hist)
        for row in hist:
            ax.plot(np.arange(row.size), 100 * row, color=f"C{i}", alpha=0.3 if hist.shape[0] > 1 else 1)
        ax.plot([], [], color=f"C{i}", label=label)
    ax.set_yscale("log")
    ax.set_xlabel("iteration")
    ax.set_ylabel("normalized RMS error (%)")
    ax.set_title(title)
    ax.legend(fontsize=8)
    return _save(fig, path)


def beam_mode_shapes(path: Path, title: str, x: np.ndarray, identified: np.ndarray,
                     true: np.ndarray, x_fine: np.ndarray | None = None,
                     true_fine: np.ndarray | None = None) -> Path:
    """Mode shapes along a beam (like Figures 5.1, 5.2): sensor positions ``x``
    (m, (n_s,)), shapes (n_s, n_modes) scaled to the true ones."""
    n = identified.shape[1]
    cols = min(n, 5)
    rows = int(np.ceil(n / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(2.6 * cols, 2.2 * rows), squeeze=False)
    for r, ax in enumerate(axes.flat):
        if r >= n:
            ax.axis("off")
            continue
        ident = _align(identified[:, r], true[:, r])
        if x_fine is not None and true_fine is not None:
            ax.plot(x_fine, true_fine[:, r], "k-", lw=0.8)
        ax.plot(x, true[:, r], "ks", ms=3, label="true")
        ax.plot(x, ident, "o", color="C1", ms=4, mfc="none", label="identified")
        ax.set_title(f"mode {r + 1}", fontsize=9)
        ax.tick_params(labelsize=7)
    axes[0, 0].legend(fontsize=7)
    fig.suptitle(title, fontsize=10)
    return _save(fig, path)


def membrane_mode_shapes(path: Path, title: str, xy: np.ndarray, identified: np.ndarray,
                         true: np.ndarray) -> Path:
    """Membrane mode shapes on the node grid (like Figure 5.4): true (top row)
    and identified (bottom row); ``xy`` (n_nodes, 2) m, shapes (n_nodes, n_modes)."""
    n = identified.shape[1]
    fig, axes = plt.subplots(2, n, figsize=(2.2 * n, 4.4), squeeze=False)
    for r in range(n):
        pair = (true[:, r], _align(identified[:, r], true[:, r]))
        vmax = 1.05 * max(np.abs(s).max() for s in pair)
        for row, shape in enumerate(pair):
            ax = axes[row, r]
            ax.tricontourf(xy[:, 0], xy[:, 1], shape, levels=np.linspace(-vmax, vmax, 13), cmap="coolwarm")
            ax.set_aspect("equal")
            ax.set_xticks([])
            ax.set_yticks([])
            ax.set_title(f"{'true' if row == 0 else 'identified'} {r + 1}", fontsize=8)
    fig.suptitle(title, fontsize=10)
    return _save(fig, path)


def _align(shape: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Scale ``shape`` to best fit ``reference`` in the least-squares sense."""
    denom = float(shape @ shape)
    return shape * (float(shape @ reference) / denom) if denom > 0 else shape


def coverage(path: Path, title: str, rows: dict[str, dict[str, float]]) -> Path:
    """95 % interval coverage per parameter kind (bars) for each results file
    (``rows[name][kind]`` in [0, 1]), with the calibrated band 0.90-0.98."""
    names = list(rows)
    kinds = list(dict.fromkeys(k for r in rows.values() for k in r))
    fig, ax = plt.subplots(figsize=(7, 3.6))
    width = 0.8 / max(1, len(kinds))
    x = np.arange(len(names))
    for i, kind in enumerate(kinds):
        ax.bar(x + i * width, [rows[n].get(kind, np.nan) for n in names], width, label=kind)
    ax.axhspan(0.90, 0.98, color="0.85", zorder=0, label="calibrated (0.90-0.98)")
    ax.axhline(0.95, color="k", lw=0.8)
    ax.set_xticks(x + 0.4 - width / 2, names, rotation=20, ha="right", fontsize=7)
    ax.set_ylim(0, 1.05)
    ax.set_ylabel("95 % interval coverage")
    ax.set_title(title)
    ax.legend(fontsize=7, loc="lower left")
    return _save(fig, path)
