"""The Python API: one call per job, each returning plain data and printing
nothing (the command line is a thin layer over these).

    import structbench as sb
    sb.run_campaign("campaigns/ch3.toml", "out/ch3")            # traces, truth.json, status.json
    doc = sb.identify("out/ch3", "least-squares", groups=["harmonic"], samples=8)
    scores = sb.score("out/ch3")                                 # per results file: summary and runs
    gates = sb.check("out/ch3")                                  # rows of [check] gates

Units are SI throughout (rad/s, m, N, kg).
"""
from __future__ import annotations

import importlib
import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

__all__ = ["DISSERTATION", "BuiltFmu", "Campaign", "CampaignStatus", "Method", "UserError", "build_fmus", "check",
           "export_modes", "export_traces", "frf", "identify", "import_data", "list_traces", "load_campaign", "methods",
           "model_geometry", "modes", "plan", "plot_modes", "reproduce", "reproduce_table", "results_file",
           "run_campaign", "score", "write_junit"]

# Names this module passes on from the subpackages, imported on first use
# (module __getattr__): each call below imports what it needs when it runs,
# so importing the API (and the command line's --help) stays cheap.
_REEXPORTED = {"DISSERTATION": "structbench.models", "Campaign": "structbench.harness.campaign",
               "load_campaign": "structbench.harness.campaign", "CampaignStatus": "structbench.harness.folder",
               "run_campaign": "structbench.harness.run", "Method": "structbench.dispatch.methods",
               "methods": "structbench.dispatch.methods", "UserError": "structbench.models.errors"}

if TYPE_CHECKING:  # what static checkers see
    from structbench.dispatch.methods import Method, methods
    from structbench.harness.campaign import Campaign, load_campaign
    from structbench.harness.folder import CampaignStatus
    from structbench.harness.run import run_campaign
    from structbench.identifier.frf.folder import FolderFrfs
    from structbench.models import DISSERTATION
    from structbench.models.errors import UserError


def __getattr__(name: str) -> Any:
    """A name passed on from a subpackage, imported on first use."""
    if name in _REEXPORTED:
        value = getattr(importlib.import_module(_REEXPORTED[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


@dataclass(frozen=True)
class BuiltFmu:
    """An FMU of :func:`build_fmus`: its structure, file, whether it was
    (re)built now (False: already up to date) and the model's DOF count."""

    structure: str
    path: Path
    built: bool
    n_dof: int


def modes(structure: str | Path, count: int = 10) -> dict[str, Any]:
    """Natural frequencies of a built-in structure or TOML model:
    ``{"structure", "n_dof", "omega" (rad/s, rigid-body 0.0), "lambda" (omega^2),
    "kind" ("finite-element" or "modal"), "n_modes"}``: a finite-element model
    has one mode per DOF, a modal model its own number of modes and ``n_dof``
    points where forces act and sensors sit."""
    from structbench.models import ModalModel, load_model
    from structbench.models.errors import UserError
    if count < 1:
        raise UserError("must be at least 1", field="--count")
    model = load_model(structure)
    m = model.modes(count)
    modal = isinstance(model, ModalModel)
    return {"structure": model.name, "n_dof": model.n_dof,
            "omega": [float(w) for w in m.omega], "lambda": [float(v) for v in m.lam],
            "kind": "modal" if modal else "finite-element", "n_modes": model.n_modes if modal else model.n_dof}


def plan(campaign: str | Path, method: str, **options: Any) -> dict[str, Any]:
    """Plan a test before running it (docs/plan.md): the predicted standard
    errors (Cramer-Rao bounds) of what ``method`` (``least-squares``,
    ``modal``) identifies from a campaign's test, on the campaign's model;
    options ``model``, ``test``, ``candidates`` + ``sensors`` (a sensor
    layout, written as a campaign file; ``criterion`` ``frequencies``,
    ``d-optimal`` or ``effective-independence``, ``target_modes``), ``drives``
    (candidate excitation points of a free decay's impulse), ``verify`` (Monte Carlo
    repetitions), ``seed``, ``jobs``, ``progress``. Returns the plan document."""
    from structbench.planning import plan as make_plan
    return make_plan(campaign, method, **options)


def build_fmus(structures: Sequence[str | Path] | None = None, out: str | Path | None = None) -> list[BuiltFmu]:
    """Build FMI 2.0 co-simulation FMUs of built-in structures or TOML models
    (default: the dissertation's five) into ``out`` (default
    :func:`~structbench.fmus.default_fmu_dir`); FMUs already built from the
    same model and code are left untouched."""
    from structbench.fmus import build_fmu, built_module, default_fmu_dir, fmu_filename
    from structbench.models import DISSERTATION, load_model
    from structbench.models.errors import UserError
    folder = Path(out) if out is not None else default_fmu_dir()
    if folder.exists() and not folder.is_dir():
        raise UserError("is a file, expected a folder", field="--out")
    built = []
    for model in [load_model(name) for name in structures or DISSERTATION]:
        target = folder / fmu_filename(model.name)
        before = built_module(target) if target.exists() else None
        path = build_fmu(model, folder)
        built.append(BuiltFmu(model.name, path, built_module(path) != before, model.n_dof))
    return built


def list_traces(folder: str | Path) -> dict[str, Any]:
    """What a campaign folder holds: status summary, truth presence, tests
    with their trace files, sampling (s) and channels."""
    from structbench.dispatch.listing import listing
    return listing(Path(folder))


def identify(campaign_dir: str | Path, method: str, *, model: str | Path | None = None,
             groups: Sequence[str] | None = None, tests: Sequence[str] | None = None, joint: bool = False,
             tag: str | None = None, progress: Callable[[int, int], None] | None = None,
             jobs: int | None = None, prior: str | Path | None = None, repetitions: int | None = None,
             **options: Any) -> dict[str, Any]:
    """Identify every run of a campaign folder with ``method`` (see
    :func:`methods`, plugins included; its options as keywords, e.g.
    ``samples=8``) and write ``results/<method>[-<tag>].json``; returns that
    document (docs/results-format.md). ``progress`` receives (runs done, runs
    in all) after every run; ``jobs`` processes identify runs in parallel
    (default: one per available core; 1: in this process), with the same results.
    ``prior``: the starting model of updating and perturbation (a built-in
    name, TOML model, ``prior.json`` or results file whose parameter values
    are set on the structure); default the campaign's ``[prior]``
    (``DIR/prior.json``), else the ``-postulated`` variant; never the truth.
    ``repetitions``: identify only the first that many repetitions."""
    from structbench.dispatch.runs import identify_folder
    document, _ = identify_folder(campaign_dir, method, str(model) if model is not None else None,
                                  groups, tests, joint, tag, options, progress, jobs, prior, repetitions)
    return document


def frf(campaign_dir: str | Path, estimator: str = "H1", *, groups: Sequence[str] | None = None,
        plot: bool = True, **options: Any) -> FolderFrfs:
    """FRFs (``H1``, ``H2`` or ``Hv``) with coherence and confidence bands of
    every test group of a campaign folder that has a force (random, impulse
    and stepped-sine tests), written to ``DIR/frf/<group>.h5``
    (docs/frf-format.md) with a plot ``DIR/frf/<group>.png``. ``options`` go
    to :func:`structbench.identifier.frf.estimate` (``responses``, ``force``,
    ``analysis``, ``segment`` s, ``overlap``, ``window``, ``blocks``,
    ``confidence``). Returns a ``FolderFrfs``: ``frfs``, ``files``,
    ``plots`` and ``skipped`` per group."""
    from structbench.identifier.frf.folder import frf_folder
    return frf_folder(campaign_dir, estimator, groups=groups, plot=plot, **options)


def results_file(campaign_dir: str | Path, method: str, tag: str | None = None) -> Path:
    """Where :func:`identify` writes: ``CAMPAIGN_DIR/results/<method>[-<tag>].json``."""
    from structbench.identifier.io.results import result_path
    return result_path(campaign_dir, method, tag)


def score(campaign_dir: str | Path) -> dict[str, Any]:
    """Scores of every results file against ``truth.json``, keyed by file
    stem: ``{"method", "summary" (medians, 10-90 % spreads), "runs"}``."""
    from structbench.evaluation.scores import score_campaign
    return score_campaign(campaign_dir)


def check(campaign_dir: str | Path, results: Sequence[str] | None = None) -> list[dict[str, Any]]:
    """The campaign's ``[check]`` gates against its scores: one row per
    (results file, gate) with ``campaign``, ``results``, ``gate``, ``value``,
    ``threshold`` and ``ok``; ``results``: only these results file stems."""
    from structbench.evaluation.gates import check_campaign
    return check_campaign(campaign_dir, results)


def write_junit(rows: Sequence[dict[str, Any]], path: str | Path, time: float = 0.0,
                error: tuple[str, str] | None = None) -> Path:
    """Gate rows of :func:`check` as a JUnit XML report at ``path`` (one
    test case per gate, a failure naming value, threshold and campaign);
    ``time``: the check's duration (s); ``error`` = (campaign, message):
    instead one test case in error, for a check that could not be made."""
    from structbench.evaluation.junit import write_junit as write
    return write(rows, path, time, error)


def reproduce(out: str | Path = "out/reproduce", repetitions: int | None = 20, jobs: int | None = None,
              progress: Callable[[str], None] | None = None, keep_traces: bool = False) -> dict[str, Any]:
    """The dissertation end to end: every case through FMUs, traces,
    identifiers and scoring into ``out``; writes ``summary.json`` and
    ``report.md`` (with figures) there and returns the summary. ``progress``
    receives one line per stage. Each case's trace files are deleted once it
    is scored unless ``keep_traces`` (about 0.55 GB). A second call resumes."""
    from structbench.evaluation.report import write_report
    from structbench.evaluation.reproduce import run_all, summarize
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    scores = run_all(out, repetitions, jobs, progress or (lambda line: None), keep_traces)
    summary = summarize(scores)
    (out / "summary.json").write_text(json.dumps(summary, indent=1) + "\n")
    write_report(out, summary, scores)
    return summary


def reproduce_table(summary: dict[str, Any]) -> list[tuple[str, str, str]]:
    """Rows (case, the dissertation's figure, this run's) of a reproduce summary."""
    from structbench.evaluation.report import table_rows
    return table_rows(summary)


def import_data(files: Sequence[str | Path], out: str | Path, map_file: str | Path | None = None,
                name: str | None = None, report: Callable[[str], None] | None = None) -> list[Path]:
    """Measured files (UFF 58 ASCII or binary ``.uff``/``.unv``, ``.csv``,
    SEP005 ``.json``) into the new trace folder ``out``: one trace per file,
    SI units from the files' unit fields, the sensor map (TOML) for what the
    files lack or what it overrides, ``name`` the campaign name. Returns the
    trace files; a bad file raises :class:`UserError` naming it and leaves no
    folder behind. ``report`` receives one line per channel the map overrides.
    UFF files' geometry goes to ``out/geometry.json``, their modes (dataset
    55) to ``out/results/``, their FRFs (dataset 58 function types 2-9) to
    ``out/frf/*.h5`` (docs/labdata.md); the files written come after the traces."""
    from structbench.labdata.importer import import_files
    return import_files(files, out, map_file, name, report, _write_imported_frf)


def _write_imported_frf(path: Path, arrays: dict[str, Any]) -> Path:
    """An FRF file (docs/frf-format.md) from the arrays of imported UFF spectra."""
    from structbench.identifier.io.frf_files import ChannelInfo, Frf, write_frf
    fields = {k: v for k, v in arrays.items() if k not in ("force", "responses")}
    return write_frf(path, Frf(**fields, force=ChannelInfo(**arrays["force"]),
                               responses=[ChannelInfo(**r) for r in arrays["responses"]]))


def model_geometry(structure: str | Path, out: str | Path | None = None) -> dict[str, Any]:
    """The geometry document (docs/geometry-format.md: nodes in m, elements)
    of a built-in structure or TOML model, from its node coordinates;
    written to ``out`` as JSON when given."""
    from structbench.labdata.geometry import geometry_from_model, write_geometry
    from structbench.models import load_model
    geometry = geometry_from_model(load_model(structure))
    if out is not None:
        write_geometry(out, geometry)
    return geometry.document()


def plot_modes(campaign_dir: str | Path, geometry: str | Path | None = None, animate: str | None = None,
               out: str | Path | None = None, scale: float = 0.1, run: int = 0) -> list[Path]:
    """Draw each mode of the modal results ``CAMPAIGN_DIR/results/*.json``
    on the geometry: one PNG per mode (undeformed in grey, deformed in
    colour, the largest displacement ``scale`` times the geometry's size)
    and, with ``animate`` ``"gif"`` (Pillow) or ``"html"`` (JavaScript), one
    animation per mode, into ``out`` (default ``CAMPAIGN_DIR/modes``).
    ``geometry``: a geometry file; default ``CAMPAIGN_DIR/geometry.json``,
    else the results' structure's node coordinates. ``run``: which run of
    each results file (0-based; the last if it has fewer). Returns the files."""
    from structbench.evaluation.mode_plots import modal_results, plot_modes as plot
    from structbench.labdata.geometry import FILE_NAME, geometry_from_model, read_geometry
    from structbench.models import load_model
    from structbench.models.errors import ModelError, UserError
    folder = Path(campaign_dir)
    results = modal_results(folder)
    if geometry is None and (folder / FILE_NAME).is_file():
        geometry = folder / FILE_NAME
    if geometry is not None:
        shape = read_geometry(geometry)
    else:
        structure = next((h.get("structure") or r.get("structure") for _, h, runs in results for r in runs[:1]), "")
        try:
            shape = geometry_from_model(load_model(structure))
        except (ModelError, OSError):
            raise UserError(f"no {FILE_NAME} in {folder} and the results' structure {structure!r} is not a model: "
                            "give --geometry FILE", field="--geometry") from None
    return plot(shape, results, Path(out) if out is not None else folder / "modes", animate, scale, run)


def export_modes(campaign_dir: str | Path, out: str | Path, results: str | None = None) -> Path:
    """The modal results of a campaign folder as UFF dataset 55 (ASCII) at
    ``out``: every run of ``results/<results>.json`` (default: the only
    results file with mode shapes), one dataset per mode (docs/labdata.md)."""
    from structbench.identifier.io.results import read_results
    from structbench.labdata.uff55 import write_uff55
    from structbench.models.errors import UserError
    folder = Path(campaign_dir) / "results"
    files = [folder / f"{results}.json"] if results else sorted(folder.glob("*.json"))
    chosen = [(p, *read_results(p)) for p in files if p.is_file()]
    chosen = [(p, h, runs) for p, h, runs in chosen if any(r.mode_shapes or r.mode_shapes_complex for r in runs)]
    if len(chosen) != 1:
        names = ", ".join(p.stem for p, _, _ in chosen) or "none"
        raise UserError(f"{len(chosen)} results files with mode shapes in {folder} ({names}); name one with "
                        "--results", field="--results" if results else "DIR")
    path, header, runs = chosen[0]
    return write_uff55(out, [r.to_dict() for r in runs], f"{header['method']} {path.stem}")


def export_traces(campaign_dir: str | Path, fmt: str, out: str | Path, binary: bool = True) -> list[Path]:
    """A campaign's traces as ``uff58`` (binary, or ASCII with
    ``binary=False``), ``csv`` or ``sep005`` files in ``out``, one per trace,
    with ``out/sensor-map.toml``; ``import_data(files, ..., map_file=that map)``
    gives the traces back. ``uff58`` also writes the FRFs of :func:`frf`
    (``DIR/frf/*.h5``), if any, as ``out/frf/<group>.uff`` (function type 4,
    docs/labdata.md). Returns the data files."""
    from structbench.labdata.exporter import export_traces as export
    written = export(campaign_dir, fmt, out, binary)
    if fmt == "uff58":
        from structbench.identifier.frf.folder import frf_files
        from structbench.identifier.io.frf_files import read_frf
        from structbench.labdata.frf_export import write_frf_uff58
        written += [write_frf_uff58(Path(out) / "frf" / f"{p.stem}.uff", read_frf(p), binary, p.name)
                    for p in frf_files(campaign_dir)]
    return written
