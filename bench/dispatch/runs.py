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

import tomllib
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


def campaign_model(folder: Path, structure: str) -> tuple[str | None, Model | None]:
    """The TOML model that the folder's copy of its campaign
    (``campaign.toml``) names as its structure: (the file name as written,
    the model or None). A relative name is relative to the campaign file,
    which the copy does not record: it is looked for beside the folder, from
    the working folder and in the folder, and taken only when its model is
    the ``structure`` the traces name."""
    try:
        ref = tomllib.loads((folder / "campaign.toml").read_text(encoding="utf-8")).get("structure")
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return None, None
    if not isinstance(ref, str) or not ref.endswith(".toml"):
        return None, None
    for base in (folder.parent, Path.cwd(), folder):
        candidate = (base / ref).resolve()  # an absolute ref stays itself
        try:
            model = load_model(candidate) if candidate.is_file() else None
        except ModelError:
            continue
        if model is not None and model.name == structure:
            return ref, model
    return ref, None


def resolve_model(name: str | None, traces: Sequence[Trace | TraceInfo], chosen: Method,
                  folder: Path | None = None) -> Model | None:
    """The given model, else the structure named by the traces (its
    ``-postulated`` variant for methods that start from one): a built-in
    name, or the TOML model file of the campaign run into ``folder``;
    ``None`` when the method can do without and the structure is not a
    known model."""
    if chosen.model == "none":
        return None
    if name is not None:
        return load_model(name)
    structure = traces[0].structure
    if chosen.postulated and f"{structure}-postulated" in STRUCTURES:
        structure = f"{structure}-postulated"
    try:
        return load_model(structure)  # a built-in name (or a TOML path an imported folder's map gave)
    except ModelError:
        pass
    ref, model = campaign_model(folder, structure) if folder is not None else (None, None)
    if model is not None:
        return model
    if chosen.model == "optional":
        return None
    where = (f" and its TOML model {ref!r} (campaign.toml) is not found beside {folder} nor in the working folder"
             if ref is not None else "")
    raise IdentificationError(f"the traces' structure {structure!r} is not a known model{where}; give --model",
                              field="--model")


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
    resolved = resolve_model(model, infos, chosen, folder)
    runs = group_runs(infos, groups, tests, joint)
    results = identify_runs([[t.path for t in run] for run in runs], chosen, resolved, settings, jobs, progress)
    document = results_document(chosen.name, results, str(infos[0].attrs.get("campaign", "")),
                                model or (resolved.name if resolved is not None else infos[0].structure),
                                {"group": list(groups) if groups else None,
                                 "test": list(tests) if tests else None, "joint": joint} | settings)
    path = write_results(result_path(folder, chosen.name, tag), document)
    write_diagrams(document, path)
    return document, path
