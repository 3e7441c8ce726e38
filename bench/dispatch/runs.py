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
from structbench.identifier.io.json_checks import load_json
from structbench.identifier.io.results import result_path, results_document, write_results
from structbench.identifier.io.traces import Trace, TraceInfo, read_infos
import numpy as np

from structbench.models import STRUCTURES, ModalModel, Model, ModelError, Structure, load_model

from .diagrams import write_diagrams
from .methods import Method, method
from .parallel import identify_runs

T = TypeVar("T", Trace, TraceInfo)
PRIOR_FILE = "prior.json"  # written by ``run`` from a campaign's [prior] (harness/prior.py)
PRIOR_FORMAT = "structbench-prior"


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


NEEDS_PRIOR = ("method {method} starts from a prior model (starting values) and the traces' structure {structure!r} "
               "has none that is not the truth: give one with --prior MODEL.toml (or a results file) on the "
               "command line, prior= in sb.identify, or a [prior] table in the campaign "
               "(model = \"FILE.toml\" or scale = [0.5, 2.0], docs/campaign-format.md)")


def topology(model: Model) -> Model:
    """``model`` with the values it would hand an identifier replaced by ones
    that carry no information: every unknown parameter 1.0 (SI unit; a
    modal model's nonzero frequencies 1 rad/s, damping 0). Known kinds keep
    their values (they are part of the structure's description)."""
    if isinstance(model, ModalModel):
        return ModalModel(model.name, np.where(np.asarray(model.omega) > 0, 1.0, 0.0), model.shape_function,
                          model.points, np.zeros(model.n_modes))
    p = model.values.copy()
    p[model.kind_mask()] = 1.0
    return model.with_values(p)


def _json(path: Path) -> dict[str, Any] | None:
    """A JSON prior file's document, None when ``path`` is not a .json file."""
    if path.suffix != ".json":
        return None
    doc = load_json(path)
    if not isinstance(doc, dict) or doc.get("format") not in (PRIOR_FORMAT, "structbench-result"):
        raise IdentificationError(f"{path}: a JSON prior must be a prior.json ({PRIOR_FORMAT}) or a results file "
                                  "with parameters (structbench-result)", field="--prior")
    return doc


def prior_values(doc: dict[str, Any], source: str) -> tuple[dict[str, float], dict[str, float]]:
    """(value, standard error) by parameter label of a prior document: a
    ``prior.json``, or a results file (the median over its runs of each
    parameter's value and of its ``std_error``; errors only where every run states one)."""
    if doc.get("format") == PRIOR_FORMAT:
        return {p["label"]: float(p["value"]) for p in doc.get("parameters", [])}, {}
    runs = [r for r in doc.get("runs") or [] if r.get("parameters")]
    if not runs:
        raise IdentificationError(f"{source}: the results file holds no identified parameters", field="--prior")
    labels = [p["label"] for p in runs[0]["parameters"]]
    table = {lab: [] for lab in labels}
    errs = {lab: [] for lab in labels}
    for run in runs:
        for p in run["parameters"]:
            table.setdefault(p["label"], []).append(float(p["value"]))
            errs.setdefault(p["label"], []).append(p.get("std_error"))
    values = {lab: float(np.median(v)) for lab, v in table.items()}
    std = {lab: float(np.median(e)) for lab, e in errs.items() if e and all(x is not None for x in e)}
    return values, std


def with_prior(model: Model, values: dict[str, float], source: str) -> Model:
    """``model`` with the parameters of ``values`` (by label) set."""
    if not isinstance(model, Structure):
        raise IdentificationError(f"{source}: a prior of parameter values needs a finite-element model, "
                                  f"{model.name} is modal", field="--prior")
    labels = [p.label for p in model.parameters]
    unknown = sorted(set(values) - set(labels))
    if unknown:
        raise IdentificationError(f"{source}: parameter(s) {', '.join(unknown[:5])} are not in {model.name}",
                                  field="--prior")
    p = model.values.copy()
    for i, label in enumerate(labels):
        if label in values:
            p[i] = values[label]
    return model.with_values(p)


def _structure_model(structure: str, chosen: Method, folder: Path | None) -> Model | None:
    """The traces' structure as a model (built-in or the campaign's TOML file)."""
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


def resolve_prior(name: str | None, traces: Sequence[Trace | TraceInfo], chosen: Method,
                  folder: Path | None = None, prior: str | None = None) -> tuple[Model | None, dict[str, Any]]:
    """The model an identifier gets and where its values came from
    (``{"source": str, "std_errors": {label: value}}``), first found of:

    1. ``name`` (``--model``): that model, values and all, as given;
    2. ``prior`` (``--prior``): a model (built-in name or TOML file), or a
       ``prior.json`` or results file whose parameter values (by label) are
       set on the traces' structure (or on ``name``'s topology);
    3. ``folder/prior.json``, written by ``run`` from the campaign's ``[prior]``;
    4. for a method that starts from a prior (``chosen.postulated``): the
       structure's built-in ``-postulated`` variant, else an error saying how
       to give a prior;
    5. the traces' structure with its unknown values replaced (:func:`topology`).

    Never the values of the structure the traces name: those are the truth."""
    if chosen.model == "none":
        return None, {}
    if name is not None and prior is None:
        return load_model(name), {"source": f"--model {name}"}
    structure = traces[0].structure if name is None else str(name)
    given = Path(prior) if prior is not None else None
    if given is None and folder is not None and (folder / PRIOR_FILE).is_file():
        given = folder / PRIOR_FILE
    if given is not None:
        doc = _json(given)
        if doc is None and name is not None:
            raise IdentificationError("--model and a prior model file both give the values: give one",
                                      field="--prior")
        if doc is None:
            return load_model(given), {"source": str(prior)}
        model = load_model(name) if name is not None else _structure_model(structure, chosen, folder)
        if model is None and chosen.model == "optional":
            return None, {}
        if model is None:
            raise IdentificationError(f"{given}: the traces' structure {structure!r} is not a known model to set "
                                      "the prior's values on; give --model", field="--prior")
        values, std = prior_values(doc, str(given))
        source = str(given) + (f" ({doc['source']})" if doc.get("source") else "")
        return with_prior(topology(model), values, str(given)), {"source": source, "std_errors": std}
    if chosen.postulated:
        if f"{structure}-postulated" in STRUCTURES:
            return load_model(f"{structure}-postulated"), {"source": f"built-in {structure}-postulated"}
        raise IdentificationError(NEEDS_PRIOR.format(method=chosen.name, structure=structure), field="--prior")
    model = _structure_model(structure, chosen, folder)
    return (None, {}) if model is None else (topology(model), {"source": "topology (unknown values not used)"})


def resolve_model(name: str | None, traces: Sequence[Trace | TraceInfo], chosen: Method,
                  folder: Path | None = None, prior: str | None = None) -> Model | None:
    """The model of :func:`resolve_prior`."""
    return resolve_prior(name, traces, chosen, folder, prior)[0]


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
                    jobs: int | None = None, prior: str | Path | None = None,
                    repetitions: int | None = None, diagrams: int | None = None) -> tuple[dict[str, Any], Path]:
    """Identify every run of a campaign folder with one method and write the
    results file; returns the result document and its path. ``progress``
    receives (runs done, runs in all) after every run; ``jobs``: processes
    (default: one per available core; 1: in this process); ``prior``: the
    starting model (:func:`resolve_prior`); ``repetitions``: only the runs of
    the first that many repetitions (by repetition number); ``diagrams``: the
    modal method's stabilisation diagrams of the first that many runs only
    (default: of every run)."""
    folder = Path(campaign_dir)
    if not folder.is_dir():
        raise IdentificationError(f"no such campaign folder {folder}", field="CAMPAIGN_DIR")
    chosen = method(method_name)
    settings = chosen.options(options or {})
    infos = read_infos(folder)
    resolved, origin = resolve_prior(model, infos, chosen, folder, str(prior) if prior is not None else None)
    runs = group_runs(infos, groups, tests, joint)
    if repetitions is not None:
        if repetitions < 1:
            raise IdentificationError(f"repetitions must be at least 1, got {repetitions}", field="repetitions")
        first = sorted({run[0].repetition for run in runs})[:repetitions]
        runs = [run for run in runs if run[0].repetition in first]
    results = identify_runs([[t.path for t in run] for run in runs], chosen, resolved, settings, jobs, progress)
    document = results_document(chosen.name, results, str(infos[0].attrs.get("campaign", "")),
                                model or (resolved.name if resolved is not None else infos[0].structure),
                                {"group": list(groups) if groups else None,
                                 "test": list(tests) if tests else None, "joint": joint}
                                | ({"repetitions": repetitions} if repetitions is not None else {}) | settings)
    if origin:
        document["prior"] = origin
    path = write_results(result_path(folder, chosen.name, tag), document)
    write_diagrams(document, path, diagrams)
    return document, path
