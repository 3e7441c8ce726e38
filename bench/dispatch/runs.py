"""Identify from a campaign folder: traces grouped into runs, the model
resolved, one :class:`Identification` per run, the results file written.

One run per (test group, repetition): the traces of a group's tests (a
stepped sine's frequencies, say) with the same repetition index are
identified together; ``joint`` puts the selected groups of one repetition
together (two impulse tests averaged by the Rayleigh method, for instance).
The runs go to ``CAMPAIGN_DIR/results/<method>[-<tag>].json``
(docs/results-format.md), with a stabilisation diagram PNG per run for the
modal method. Grouping reads only the files' root attributes; the samples
are read run by run, by the process that identifies the run
(:mod:`.parallel`).
"""
from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from fnmatch import fnmatch
from pathlib import Path
from typing import Any, TypeVar

from structbench.identifier.errors import IdentificationError
from structbench.identifier.io.results import result_path, results_document, write_results
from structbench.identifier.io.traces import Trace, TraceInfo, read_infos
from structbench.models import STRUCTURES, Model, ModelError, load_model

from .diagrams import write_diagrams
from .methods import Method, method
from .parallel import identify_runs

T = TypeVar("T", Trace, TraceInfo)


def resolve_model(name: str | None, traces: Sequence[Trace | TraceInfo], chosen: Method) -> Model | None:
    """The given model or the structure named by the traces (its
    ``-postulated`` variant for methods that start from one); ``None`` when
    the method can do without and the structure is not a known model."""
    if chosen.model == "none":
        return None
    if name is not None:
        return load_model(name)
    structure = traces[0].structure
    if chosen.postulated and f"{structure}-postulated" in STRUCTURES:
        structure = f"{structure}-postulated"
    try:
        return load_model(structure)
    except ModelError:
        if chosen.model == "optional":
            return None
        raise IdentificationError(f"the traces' structure {structure!r} is not a known model; give --model",
                                  field="--model") from None


def group_runs(traces: list[T], groups: Sequence[str] | None = None, tests: Sequence[str] | None = None,
               joint: bool = False) -> list[list[T]]:
    """Traces (or their :class:`TraceInfo`) per run: by (group, repetition),
    or by repetition with ``joint``, of the selected groups and tests (shell patterns)."""
    def group(t: Trace | TraceInfo) -> str:
        return str(t.attrs.get("group", t.test))

    present = sorted({group(t) for t in traces})
    unknown = sorted(set(groups or []) - set(present))
    if unknown:
        raise IdentificationError(f"no test group {', '.join(unknown)}; present: {', '.join(present)}",
                                  field="--group")
    chosen = [t for t in traces if (groups is None or group(t) in groups)
              and (tests is None or any(fnmatch(t.test, p) for p in tests))]
    if not chosen:
        raise IdentificationError(f"no trace matches --test {' '.join(tests or [])}", field="--test")
    key = (lambda t: ("", t.repetition)) if joint else (lambda t: (group(t), t.repetition))
    out: dict[tuple[str, int], list[T]] = {}
    for t in sorted(chosen, key=lambda t: (key(t), t.test)):
        out.setdefault(key(t), []).append(t)
    return list(out.values())


def identify_folder(campaign_dir: str | Path, method_name: str, model: str | None = None,
                    groups: Sequence[str] | None = None, tests: Sequence[str] | None = None,
                    joint: bool = False, tag: str | None = None,
                    options: Mapping[str, Any] | None = None,
                    progress: Callable[[int, int], None] | None = None,
                    jobs: int | None = None) -> tuple[dict[str, Any], Path]:
    """Identify every run of a campaign folder with one method and write the
    results file; returns the result document and its path. ``progress``
    receives (runs done, runs in all) after every run; ``jobs``: processes
    (default: one per available core; 1: in this process)."""
    folder = Path(campaign_dir)
    if not folder.is_dir():
        raise IdentificationError(f"no such campaign folder {folder}", field="CAMPAIGN_DIR")
    chosen = method(method_name)
    settings = chosen.options(options or {})
    infos = read_infos(folder)
    resolved = resolve_model(model, infos, chosen)
    runs = group_runs(infos, groups, tests, joint)
    results = identify_runs([[t.path for t in run] for run in runs], chosen, resolved, settings, jobs, progress)
    document = results_document(chosen.name, results, str(infos[0].attrs.get("campaign", "")),
                                model or (resolved.name if resolved is not None else infos[0].structure),
                                {"group": list(groups) if groups else None,
                                 "test": list(tests) if tests else None, "joint": joint} | settings)
    path = write_results(result_path(folder, chosen.name, tag), document)
    write_diagrams(document, path)
    return document, path
