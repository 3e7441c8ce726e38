"""``structbench identify``: identify parameters or modes from a campaign's traces.

One run per (test group, repetition): the traces of a group's tests (a
stepped sine's frequencies, say) with the same repetition index are identified
together; ``--joint`` puts the selected groups of one repetition together
(two impulse tests averaged by the Rayleigh method, for instance). The runs
go to ``CAMPAIGN_DIR/results/<method>[-<tag>].json`` (docs/results-format.md).
"""
from __future__ import annotations

import argparse
import json
from fnmatch import fnmatch
from pathlib import Path

from identifier import least_squares, perturbation, rayleigh
from identifier.errors import IdentificationError
from identifier.integrate import METHODS as INTEGRATION_METHODS
from identifier.results import Identification, result_path, results_document, write_results
from identifier.traces import Trace, read_traces
from models import STRUCTURES, Model, ModelError, load_model

HELP = "identify parameters (least squares, perturbation) or modes (Rayleigh) from a campaign's traces"
METHODS = ("least-squares", "perturbation", "rayleigh")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("campaign_dir", type=Path, metavar="CAMPAIGN_DIR", help="output folder of structbench run")
    parser.add_argument("--method", required=True, choices=METHODS)
    parser.add_argument("--model", metavar="NAME_OR_TOML",
                        help="model with the unknown parameters (default: the traces' structure; for the "
                             "perturbation method its '-postulated' variant when there is one)")
    parser.add_argument("--group", action="append", metavar="NAME",
                        help="only this test group (repeatable; default: every group)")
    parser.add_argument("--test", action="append", metavar="PATTERN",
                        help="only tests whose name matches (shell pattern, repeatable; e.g. exact-01)")
    parser.add_argument("--joint", action="store_true", help="identify the selected groups of a repetition together")
    parser.add_argument("--tag", help="result file results/<method>-<tag>.json")
    parser.add_argument("--json", action="store_true", help="print the result document as JSON")
    ls = parser.add_argument_group("least squares")
    ls.add_argument("--samples", type=int, default=8, metavar="M", help="sample times per trace (default 8)")
    ls.add_argument("--interval", type=float, default=0.5, metavar="S",
                    help="t_k = t_0 + interval k, s (default 0.5)")
    ls.add_argument("--integration", default="auto", choices=least_squares.INTEGRATIONS,
                    help="displacements and velocities: measured when logged (auto), else integrated "
                         f"({', '.join(INTEGRATION_METHODS)})")
    ls.add_argument("--weighting", default="noise", choices=least_squares.WEIGHTINGS,
                    help="generalised least squares with the declared sensor noise (default) or plain")
    pt = parser.add_argument_group("perturbation")
    pt.add_argument("--max-iterations", type=int, default=20, metavar="N")
    pt.add_argument("--tol", type=float, default=1e-8, help="converged when max |dp/p| < tol")
    pt.add_argument("--natural-frequencies", action="store_true",
                    help="add the natural frequencies found in the free vibration (not in the dissertation)")
    ry = parser.add_argument_group("rayleigh")
    ry.add_argument("--variant", default="auto", choices=rayleigh.VARIANTS,
                    help="displacement/velocity or velocity/acceleration correlations")
    ry.add_argument("--window", default="hann", choices=rayleigh.WINDOWS, help="taper of the time averages")
    ry.add_argument("--admissible", choices=["cosine"], help="admissible functions with FE interpolation")
    ry.add_argument("--functions", type=int, metavar="K", help="number of admissible functions (default: sensors)")


def resolve_model(name: str | None, traces: list[Trace], method: str) -> Model | None:
    """The ``--model`` or the structure named by the traces (``None`` for the
    Rayleigh method when that structure is not a known model)."""
    if name is not None:
        return load_model(name)
    structure = traces[0].structure
    if method == "perturbation" and f"{structure}-postulated" in STRUCTURES:
        structure = f"{structure}-postulated"
    try:
        return load_model(structure)
    except ModelError:
        if method == "rayleigh":
            return None
        raise IdentificationError(f"the traces' structure {structure!r} is not a known model; give --model",
                                  field="--model") from None


def runs(traces: list[Trace], groups: list[str] | None, tests: list[str] | None, joint: bool
         ) -> list[list[Trace]]:
    """Traces per run: by (group, repetition), or by repetition with ``joint``,
    of the selected groups and tests."""
    def group(t: Trace) -> str:
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
    out: dict[tuple[str, int], list[Trace]] = {}
    for t in sorted(chosen, key=lambda t: (key(t), t.test)):
        out.setdefault(key(t), []).append(t)
    return list(out.values())


def identify(method: str, traces: list[Trace], model: Model | None, args: argparse.Namespace) -> Identification:
    if method == "least-squares":
        return least_squares.identify(traces, model, args.samples, args.interval, args.integration,
                                      args.weighting)
    if method == "perturbation":
        return perturbation.identify(traces, model, args.max_iterations, args.tol, args.natural_frequencies)
    return rayleigh.identify(traces, model, args.variant, args.window, args.admissible, args.functions)


def options(args: argparse.Namespace) -> dict:
    keys = {"least-squares": ("samples", "interval", "integration", "weighting"),
            "perturbation": ("max_iterations", "tol", "natural_frequencies"),
            "rayleigh": ("variant", "window", "admissible", "functions")}[args.method]
    return {"group": args.group, "test": args.test, "joint": args.joint} | {k: getattr(args, k) for k in keys}


def table(run: Identification) -> list[str]:
    """Human-readable lines of one run."""
    head = f"repetition {run.repetition} ({', '.join(run.tests[:3])}{', ...' if len(run.tests) > 3 else ''}): " \
           f"{run.status}" + (f" after {run.iterations} iterations" if run.iterations is not None else "")
    lines = [head + (f" - {run.message}" if run.message else "")]
    for p in run.parameters:
        err = f" +- {p.std_error:.3g}" if p.std_error is not None else ""
        start = f"   (from {p.initial:.6g})" if p.initial is not None else ""
        lines.append(f"  {p.label:16s} {p.value:14.6g}{err:14s} {p.unit}{start}")
    for i, (w, lam) in enumerate(zip(run.omega, run.eigenvalues), start=1):
        lines.append(f"  mode {i:2d}  omega = {w:10.6f} rad/s   omega^2 = {lam:10.6f}")
    return lines


def identify_campaign(args: argparse.Namespace) -> tuple[dict, Path, list[Identification]]:
    """Identify per ``args`` (as parsed by :func:`add_arguments`) and write the
    results file; returns the document, its path and the runs."""
    if not args.campaign_dir.is_dir():
        raise IdentificationError(f"no such campaign folder {args.campaign_dir}", field="CAMPAIGN_DIR")
    traces = read_traces(args.campaign_dir)
    model = resolve_model(args.model, traces, args.method)
    results = [identify(args.method, group, model, args) for group in runs(traces, args.group, args.test, args.joint)]
    document = results_document(args.method, results, str(traces[0].attrs.get("campaign", "")),
                                args.model or (model.name if model is not None else traces[0].structure),
                                options(args))
    path = write_results(result_path(args.campaign_dir, args.method, args.tag), document)
    return document, path, results


def parse(argv: list[str]) -> argparse.Namespace:
    """Arguments of ``structbench identify`` from a list of words."""
    parser = argparse.ArgumentParser(prog="structbench identify")
    add_arguments(parser)
    return parser.parse_args(argv)


def run(args: argparse.Namespace) -> int:
    document, path, results = identify_campaign(args)
    if args.json:
        print(json.dumps(document, indent=1))
        return 0
    print(f"{args.method}: {len(results)} run(s) of {document['model']} -> {path}")
    for i, result in enumerate(results):
        print("\n".join(table(result) if i == 0 else table(result)[:1]))
    return 0
