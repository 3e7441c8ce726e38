"""FRFs of a campaign folder: one :class:`~structbench.identifier.io.frf_files.Frf`
per test group (the repetitions of a test, or the tests of a stepped sine),
written to ``DIR/frf/<group>.h5`` (``docs/frf-format.md``) with a plot
``DIR/frf/<group>.png``. Reads the traces only.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import IdentificationError
from ..io.frf_files import Frf, write_frf
from ..io.traces import read_infos, read_trace, trace_files
from . import estimate

FOLDER = "frf"


@dataclass
class FolderFrfs:
    """What :func:`frf_folder` did: ``frfs`` and ``files`` (the HDF5 files) and
    ``plots`` (PNG) per group; ``skipped`` groups with the reason (no force)."""

    frfs: dict[str, Frf] = field(default_factory=dict)
    files: dict[str, Path] = field(default_factory=dict)
    plots: dict[str, Path] = field(default_factory=dict)
    skipped: dict[str, str] = field(default_factory=dict)


def output_folder(campaign_dir: str | Path) -> Path:
    """``DIR/frf``: where the FRF files of a campaign folder go."""
    return Path(campaign_dir) / FOLDER


def frf_files(campaign_dir: str | Path) -> list[Path]:
    """The FRF files ``DIR/frf/*.h5`` of a campaign folder (sorted; may be empty)."""
    return sorted(output_folder(campaign_dir).glob("*.h5"))


def _groups(campaign_dir: str | Path) -> dict[str, list[Path]]:
    groups: dict[str, list[Path]] = {}
    for info in read_infos(trace_files(campaign_dir)):
        groups.setdefault(str(info.attrs.get("group", info.test)), []).append(info.path)
    return groups


def frf_folder(campaign_dir: str | Path, estimator: str = "H1", *, groups: Sequence[str] | None = None,
               plot: bool = True, **options: Any) -> FolderFrfs:
    """Estimate (:func:`structbench.identifier.frf.estimate`, ``options``
    passed on) and write the FRFs of every group of ``campaign_dir`` (or of
    ``groups``). A group without any force is skipped when not named, an
    error when named; no group at all with a force is an error."""
    found = _groups(campaign_dir)
    if groups is not None:
        unknown = [g for g in groups if g not in found]
        if unknown:
            raise IdentificationError(f"no test group {unknown[0]!r} in {campaign_dir} "
                                      f"(groups: {', '.join(found)})", field="groups")
    out = FolderFrfs()
    folder = output_folder(campaign_dir)
    for group in (groups if groups is not None else list(found)):
        traces = [read_trace(p) for p in found[group]]
        if not any(t.forces() for t in traces) and groups is None:
            out.skipped[group] = f"{traces[0].path.name}: no force channel and no /excitation force"
            continue
        try:
            result = estimate(traces, estimator, **options)
        except IdentificationError as err:
            if groups is None and err.field == "excitation":
                out.skipped[group] = str(err)
                continue
            raise
        out.frfs[group] = result
        out.files[group] = write_frf(folder / f"{group}.h5", result)
        if plot:
            from .plot import plot_frf  # matplotlib only when plotting
            out.plots[group] = plot_frf(result, folder / f"{group}.png")
    if not out.frfs:
        raise IdentificationError(f"no test group of {campaign_dir} has a force to refer FRFs to "
                                  f"({'; '.join(out.skipped.values())})", field="traces")
    return out
