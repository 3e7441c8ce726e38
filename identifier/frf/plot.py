"""FRF plots: magnitude (log scale, with its confidence band), phase (deg,
with its band) and coherence over frequency (Hz), one figure per
:class:`~structbench.identifier.io.frf_files.Frf`.

Draws on a :class:`matplotlib.figure.Figure` with its own Agg canvas: the
process-wide backend (and pyplot's state) stays as it is.
"""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ..io.frf_files import Frf

MAX_CURVES = 8  # responses drawn by default (the first ones)


def figure(frf: Frf, responses: Sequence[str] | None = None) -> Figure:
    """A figure of three axes (magnitude, phase in degrees, coherence) with one
    curve per response (default: the first :data:`MAX_CURVES`); the bands are
    shaded where defined. Lines with zero frequency are left out of the log axis."""
    rows = [frf.index(n) for n in responses] if responses is not None else list(range(min(MAX_CURVES,
                                                                                             len(frf.responses))))
    fig = Figure(figsize=(8.0, 7.5))
    FigureCanvasAgg(fig)
    mag_ax, phase_ax, coh_ax = fig.subplots(3, 1, sharex=True, gridspec_kw={"height_ratios": [2, 1.3, 1]})
    f = frf.frequency
    style = {"lw": 1.0, "marker": "o" if frf.analysis == "harmonic" else None, "ms": 4}  # lines: one per test
    for i in rows:
        label = f"{frf.responses[i].name} [{frf.units[i]}]"
        line, = mag_ax.plot(f, frf.magnitude[i], label=label, **style)
        color = line.get_color()
        lo, hi = frf.magnitude_band[:, i]
        if np.isfinite(lo).any():
            mag_ax.fill_between(f, lo, hi, color=color, alpha=0.2, lw=0)
        phase_ax.plot(f, np.degrees(frf.phase[i]), color=color, **style)
        plo, phi = frf.phase_band[:, i]
        if np.isfinite(plo).any():
            phase_ax.fill_between(f, np.degrees(plo), np.degrees(phi), color=color, alpha=0.2, lw=0)
        coh_ax.plot(f, frf.coherence[i], color=color, **style)
    mag_ax.set_yscale("log")
    mag_ax.set_ylabel("|H|")
    mag_ax.legend(fontsize=7, loc="best")
    phase_ax.set_ylabel("phase (deg)")
    phase_ax.set_ylim(-190, 190)
    phase_ax.set_yticks([-180, -90, 0, 90, 180])
    coh_ax.set_ylabel("coherence")
    coh_ax.set_ylim(0, 1.05)
    coh_ax.set_xlabel("frequency (Hz)")
    group = frf.attrs.get("group", "")
    mag_ax.set_title(f"{group}: {frf.estimator} per {frf.force.name} ({frf.analysis}, {frf.window}, "
                     f"{int(np.max(frf.n_averages, initial=0))} averages, bands {frf.confidence:.0%})", fontsize=9)
    for ax in (mag_ax, phase_ax, coh_ax):
        ax.grid(True, alpha=0.3)
    fig.tight_layout()
    return fig


def plot_frf(frf: Frf, path: str | Path, responses: Sequence[str] | None = None) -> Path:
    """Save :func:`figure` as a PNG at ``path``; returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    figure(frf, responses).savefig(path, dpi=100)
    return path
