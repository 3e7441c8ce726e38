"""Mode shapes drawn on the test geometry: a PNG per mode (undeformed
geometry in grey, deformed in colour) and, on request, an animation of each
mode (GIF through matplotlib's PillowWriter, or HTML with JavaScript).

Works on matplotlib ``Figure`` objects with their own Agg canvas, never
pyplot's global state or a process-wide backend. The geometry is any object
with ``nodes`` ({id: (3,) m}), ``lines`` and ``elements`` (dicts with
``nodes``) and ``direction(node, name)`` (the global unit vector of a
displacement direction, None for rotations), as
:class:`structbench.labdata.geometry.Geometry` gives them; the API hands it
over. A sensor ``<quantity>_<node>_<direction>`` moves its node along that
direction by its shape value; nodes without sensors stay where they are.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.animation import FuncAnimation, PillowWriter
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from structbench.identifier.io.results import read_results
from structbench.models.errors import UserError

FRAMES = 20  # per animated period
UNDEFORMED, DEFORMED = "undeformed nodes", "deformed nodes"


@dataclass(frozen=True)
class ModeView:
    """What one figure shows: node ids, their positions (n, 3) m, their
    displacements (n, 3) (scaled, m), the edges as index pairs' polylines,
    the plotted axes (0 x, 1 y, 2 z) and the title."""

    ids: list[int]
    positions: np.ndarray
    displacement: np.ndarray
    edges: list[list[int]]
    axes: tuple[int, ...]
    title: str


def _edges(geometry: Any, index: dict[int, int]) -> list[list[int]]:
    edges = [[index[n] for n in line["nodes"] if n in index] for line in geometry.lines]
    for element in geometry.elements:
        ring = [index[n] for n in element["nodes"] if n in index]
        edges.append(ring + ring[:1] if len(ring) > 2 else ring)
    return [e for e in edges if len(e) > 1]


def mode_view(geometry: Any, sensors: list[str], shape: np.ndarray, title: str, scale: float = 0.1) -> ModeView:
    """The view of one real mode shape over ``sensors``: the largest node
    displacement is ``scale`` times the geometry's size (its bounding box's
    diagonal, 1 m for a single point)."""
    ids = sorted(geometry.nodes)
    if not ids:
        raise UserError("the geometry has no nodes", field="--geometry")
    index = {n: i for i, n in enumerate(ids)}
    positions = np.array([geometry.nodes[n] for n in ids], dtype=float)
    moved = np.zeros_like(positions)
    placed = 0
    for name, value in zip(sensors, shape):
        _, node, direction = name.split("_", 2)
        vector = geometry.direction(int(node), direction) if int(node) in index else None
        if vector is not None and math.isfinite(value):
            moved[index[int(node)]] += value * np.asarray(vector)
            placed += 1
    if not placed:
        raise UserError(f"no sensor of {sensors[:4]}... is a translation at a node of the geometry",
                        field="--geometry")
    if placed < len(sensors):
        title += (f"\n({len(sensors) - placed} of {len(sensors)} sensors not drawn: rotations or nodes not in "
                  "the geometry)")
    size = float(np.linalg.norm(positions.max(0) - positions.min(0))) or 1.0
    peak = float(np.abs(moved).max())
    displacement = moved * (scale * size / peak if peak > 0 else 0.0)
    extent = np.ptp(np.vstack([positions, positions + displacement, positions - displacement]), axis=0)
    axes = tuple(i for i in range(3) if extent[i] > 1e-12 * size)
    if len(axes) < 2:
        axes = tuple(sorted(set(axes) | {next(i for i in (2, 1, 0) if i not in axes)}))
    return ModeView(ids, positions, displacement, _edges(geometry, index), axes, title)


def _figure(view: ModeView) -> tuple[Figure, Any, dict[str, Any]]:
    """The figure of ``view`` and the artists that move: ``deformed`` (the
    deformed nodes) and ``edges`` (deformed edges)."""
    fig = Figure(figsize=(6.4, 4.8))
    FigureCanvasAgg(fig)
    three = len(view.axes) == 3
    ax = fig.add_subplot(projection="3d" if three else None)
    labels = "xyz"

    def coords(points: np.ndarray) -> list[np.ndarray]:
        return [points[:, a] for a in view.axes]

    base = view.positions
    for edge in view.edges:
        ax.plot(*coords(base[edge]), color="0.65", linewidth=1.0)
    ax.plot(*coords(base), linestyle="none", marker="o", markersize=3, color="0.55", label=UNDEFORMED)
    moved = base + view.displacement
    edges = [ax.plot(*coords(moved[edge]), color="tab:blue", linewidth=1.6)[0] for edge in view.edges]
    deformed = ax.plot(*coords(moved), linestyle="none", marker="o", markersize=4, color="tab:red",
                       label=DEFORMED)[0]
    ax.set_xlabel(f"{labels[view.axes[0]]} (m)")
    ax.set_ylabel(f"{labels[view.axes[1]]} (m)")
    if three:
        ax.set_zlabel(f"{labels[view.axes[2]]} (m)")
        span = np.vstack([base + view.displacement, base - view.displacement])
        low, high = span.min(0), span.max(0)
        half = max(float((high - low).max()) / 2, 1e-9)
        for setter, mid in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), (low + high) / 2):
            setter(mid - half, mid + half)
    else:
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(True, linewidth=0.3)
    ax.set_title(view.title, fontsize=9)
    ax.legend(loc="best", fontsize=7)
    return fig, ax, {"deformed": deformed, "edges": edges, "three": three}


def mode_figure(view: ModeView) -> Figure:
    """A static figure of one mode (matplotlib ``Figure``, Agg canvas)."""
    return _figure(view)[0]


def _animation(view: ModeView) -> tuple[Figure, FuncAnimation]:
    fig, _, moving = _figure(view)

    def set_points(artist: Any, points: np.ndarray) -> None:
        columns = [points[:, a] for a in view.axes]
        if moving["three"]:
            artist.set_data_3d(*columns)
        else:
            artist.set_data(*columns)

    def update(frame: int) -> list[Any]:
        points = view.positions + math.cos(2 * math.pi * frame / FRAMES) * view.displacement
        set_points(moving["deformed"], points)
        for artist, edge in zip(moving["edges"], view.edges):
            set_points(artist, points[edge])
        return [moving["deformed"], *moving["edges"]]

    return fig, FuncAnimation(fig, update, frames=FRAMES, interval=60, blit=False)


def save_animation(view: ModeView, path: Path, kind: str) -> Path:
    """One period of the mode as ``gif`` (PillowWriter; needs Pillow) or
    ``html`` (a page with JavaScript controls, ``to_jshtml``)."""
    fig, animation = _animation(view)
    if kind == "gif":
        if not PillowWriter.isAvailable():
            raise UserError("GIF needs Pillow (pip install pillow); use --animate html", field="--animate")
        animation.save(path, writer=PillowWriter(fps=15), dpi=80)
    elif kind == "html":
        path.write_text("<!DOCTYPE html>\n<html><head><meta charset='utf-8'><title>"
                        f"{view.title}</title></head><body>\n{animation.to_jshtml(fps=15)}\n</body></html>\n")
    else:
        raise UserError(f"{kind!r} is not gif or html", field="--animate")
    return path


def _title(stem: str, run: dict[str, Any], k: int) -> str:
    omega = float(run["omega"][k])
    damping = (run.get("damping") or [None] * len(run["omega"]))[k]
    text = f"{stem} run {run.get('repetition', 0)} mode {k + 1}: {omega / (2 * math.pi):.4g} Hz ({omega:.4g} rad/s)"
    return text + (f", damping {100 * damping:.3g} %" if damping is not None and math.isfinite(damping) else "")


def modal_results(campaign_dir: Path) -> list[tuple[Path, dict[str, Any], list[dict[str, Any]]]]:
    """(path, header, runs) of every results file with mode shapes over sensors."""
    found = []
    for path in sorted((campaign_dir / "results").glob("*.json")):
        header, runs = read_results(path)
        dicts = [r.to_dict() for r in runs]
        if any(r.get("mode_shapes") and r.get("sensors") for r in dicts):
            found.append((path, header, dicts))
    if not found:
        raise UserError(f"no results with mode shapes in {campaign_dir / 'results'}: run structbench identify "
                        "--method modal (or rayleigh), or import a UFF 55 file", field="DIR")
    return found


def plot_modes(geometry: Any, results: list[tuple[Path, dict[str, Any], list[dict[str, Any]]]], out: Path,
               animate: str | None = None, scale: float = 0.1, run: int = 0) -> list[Path]:
    """PNG (and animation) files ``<results stem>-mode<k>.png`` in ``out``
    for every mode of run ``run`` of each results file; returns them."""
    if animate not in (None, "gif", "html"):
        raise UserError(f"{animate!r} is not gif or html", field="--animate")
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for path, _, runs in results:
        chosen = runs[min(run, len(runs) - 1)]
        for k, shape in enumerate(chosen.get("mode_shapes") or []):
            view = mode_view(geometry, chosen["sensors"], np.asarray(shape, dtype=float),
                             _title(path.stem, chosen, k), scale)
            png = out / f"{path.stem}-mode{k + 1}.png"
            mode_figure(view).savefig(png, dpi=100)
            written.append(png)
            if animate:
                written.append(save_animation(view, out / f"{path.stem}-mode{k + 1}.{animate}", animate))
    return written
