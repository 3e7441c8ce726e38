"""Report figures (matplotlib, Agg backend, PNG files): the drawing functions,
and :func:`case_figures`, the figures of one case's results (drawn by the
reproduction as soon as the case is done, and redrawn only when older than
the results they show)."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from structbench.identifier.io.results import read_results  # noqa: E402
from structbench.models import load_model  # noqa: E402

from .truth_checks import read_truth  # noqa: E402

UNITS = {"mass": "kg/m", "stiffness": "N/m"}


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


# ---- the figures of one case's results ------------------------------------------
def case_figures(out: Path, case: str) -> list[Path]:
    """The figures of case ``case`` of the reproduction in ``out`` (none for
    most cases): ch3 parameters (``m4``, ``m8``); the ch5 beam's shapes (the
    Rayleigh quotient, then the modal method); the membrane's (one record,
    then two). Each is drawn unless it is newer than what it shows."""
    folder = out / case
    if case == "ch3":
        return [_drawn(out / f"ch3-parameters-{tag}.png", folder, [f"least-squares-{tag}"], _ch3_parameters, tag)
                for tag in ("m4", "m8")]
    if case == "ch5-beam":
        return [_drawn(out / png, folder, [stem], _beam_shapes, stem, title) for png, stem, title in (
            ("ch5-beam-modes.png", "rayleigh-hann",
             "Chapter 5 beam: identified (o) vs true mode shapes (cf. Figures 5.1, 5.2)"),
            ("ch5-beam-modes-modal.png", "modal-noisy",
             "ch5 beam, 2 % noise: modal method (o) vs true mode shapes, modes 1-10"))]
    if case == "ch5-membrane":
        return [_drawn(out / f"ch5-membrane-modes-{tag}.png", folder, [f"rayleigh-{tag}"], _membrane_shapes, tag)
                for tag in ("single", "joint")]
    return []


def _drawn(path: Path, folder: Path, stems: list[str], draw, *args) -> Path:
    """``path``, drawn by ``draw(path, folder, *args)`` unless newer than the
    results ``stems`` of ``folder`` and its truth."""
    sources = [folder / "results" / f"{stem}.json" for stem in stems] + [folder / "truth.json"]
    if path.is_file() and path.stat().st_mtime_ns > max(p.stat().st_mtime_ns for p in sources):
        return path
    return draw(path, folder, *args)


def _by_kind(labels: list[str], values: np.ndarray) -> dict[str, np.ndarray]:
    """Split a (..., n_par) array by the kind in the labels ``kind[element]``."""
    kinds = [label.split("[")[0] for label in labels]
    return {k: values[..., [i for i, kk in enumerate(kinds) if kk == k]] for k in dict.fromkeys(kinds)}


def _ch3_parameters(path: Path, folder: Path, tag: str) -> Path:
    _, runs = read_results(folder / "results" / f"least-squares-{tag}.json")
    labels = runs[0].labels()
    table = {p["label"]: p["value"] for p in read_truth(folder / "truth.json")["parameters"]}
    truth = _by_kind(labels, np.array([table[label] for label in labels]))
    estimates = _by_kind(labels, np.array([r.values() for r in runs]))
    return parameter_distribution(path, f"Chapter 3, {tag}: identified vs true ({len(runs)} noise realisations)",
                                  truth, estimates, UNITS)


def _shapes(folder: Path, stem: str) -> tuple[np.ndarray, np.ndarray]:
    """Identified shapes of run 0 and the true ones at the same sensors, (n_s, n_modes)."""
    _, runs = read_results(folder / "results" / f"{stem}.json")
    run = runs[0]
    truth = read_truth(folder / "truth.json")
    rows = {tuple(d): i for i, d in enumerate(truth["sensor_dofs"])}
    pick = [rows[(int(c.split("_")[1]), c.split("_", 2)[2])] for c in run.sensors]
    ident = np.array(run.mode_shapes).T
    return ident, np.array(truth["mode_shapes"])[pick][:, :ident.shape[1]]


def _beam_shapes(path: Path, folder: Path, stem: str, title: str) -> Path:
    """Modes 1-10 of the ch5 beam identified by ``stem`` against the true ones."""
    beam = load_model("ch5-simply-supported-beam")
    ident, true = _shapes(folder, stem)
    x_fine = np.linspace(0, 10, 400)
    return beam_mode_shapes(path, title, beam.points, ident[:, :10], true[:, :10], x_fine,
                            beam.shape_function(x_fine)[:, :10])


def _membrane_shapes(path: Path, folder: Path, tag: str) -> Path:
    membrane = load_model("ch5-membrane")
    xy = np.array([membrane.nodes[n][:2] for n, _ in membrane.dofs])
    ident, true = _shapes(folder, f"rayleigh-{tag}")
    return membrane_mode_shapes(path, f"Chapter 5 membrane ({tag}): five lowest modes (cf. Figure 5.4)",
                                xy, ident[:, :5], true[:, :5])
