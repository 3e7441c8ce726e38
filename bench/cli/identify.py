"""``structbench identify``: identify parameters or modes from a campaign's traces.

One run per (test group, repetition), or per repetition with ``--joint``;
the runs go to ``CAMPAIGN_DIR/results/<method>[-<tag>].json``
(docs/results-format.md). Method options left out take the method's defaults.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from structbench import api

from .progress import bar, interactive

HELP = ("identify parameters (least squares, perturbation, updating) or modes (Rayleigh, modal) from a "
        "campaign's traces")

# The built-in methods' help, defaults and choices as api.methods() has them
# (tests/test_cli_startup.py holds the two equal): --help shows them without
# importing the identifiers and numpy. Plugins are listed by entry point name.
BUILTIN: dict[str, tuple[str, dict[str, Any], dict[str, tuple[Any, ...]]]] = {
    "least-squares": (
        "chapter 3: element mass, damping and stiffness by least squares on the equations of motion",
        {"estimator": "bias-compensated", "samples": None, "interval": 0.5, "integration": "auto",
         "weighting": "noise", "domain": "auto"},
        {"estimator": ("bias-compensated", "ols"), "integration": ("auto", "zoh-simpson", "simpson", "trapezoid"),
         "weighting": ("noise", "none"), "domain": ("auto", "time", "frequency")}),
    "perturbation": (
        "chapter 4: iterative frequency-domain perturbation from a postulated model",
        {"max_iterations": 20, "tol": 1e-8, "natural_frequencies": False}, {}),
    "rayleigh": (
        "chapter 5: modes from free response by a pseudo-Rayleigh quotient",
        {"variant": "auto", "window": "hann", "admissible": None, "functions": None},
        {"variant": ("auto", "displacement", "velocity"), "window": ("hann", "rectangular"),
         "admissible": (None, "cosine")}),
    "modal": (
        "output-only or free-decay modes with damping: SSI-cov, automatic order selection, jackknife errors",
        {"quantity": "auto", "block_rows": None, "max_order": 80, "references": 20, "segments": 8,
         "min_fraction": 0.3, "refine": "auto", "uncertainty": "jackknife", "input": "auto", "short_lags": "on"},
        {"quantity": ("auto", "displacement", "velocity", "acceleration"), "refine": ("auto", "off"),
         "uncertainty": ("jackknife", "off"), "input": ("auto", "off", "on", "poles"), "short_lags": ("off", "on")}),
    "updating": (
        "finite-element model updating from identified modes (a modal results or modal-data file, "
        "--option modal=FILE) starting from the model given as the prior",
        {"modal": None, "kinds": None, "bounds": [-0.9, 3.0], "starts": 1, "scatter": 0.3, "seed": 0,
         "regularisation": "auto", "rank_tol": 1e-06, "shape_std": None, "modes": None, "parameters": None,
         "max_nfev": 200, "tol": 1e-10, "localise": False, "level": 0.001, "data": "auto"}, {}),
}
PLUGIN_GROUP = "structbench.identifiers"  # docs/plugins.md


def plugin_names() -> list[str]:
    """Installed plugin methods by entry point name (not loaded)."""
    from importlib.metadata import entry_points
    return sorted({e.name for e in entry_points(group=PLUGIN_GROUP)} - set(BUILTIN))


def _default(method: str, option: str) -> Any:
    return BUILTIN[method][1][option]


def _choices(method: str, option: str) -> tuple[Any, ...]:
    return BUILTIN[method][2][option]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    plugins = plugin_names()
    parser.add_argument("campaign_dir", type=Path, metavar="CAMPAIGN_DIR", help="output folder of structbench run")
    parser.add_argument("--method", required=True, choices=[*BUILTIN, *plugins],
                        help="; ".join([f"{name}: {about[0]}" for name, about in BUILTIN.items()]
                                       + [f"{name}: plugin (docs/plugins.md)" for name in plugins]))
    parser.add_argument("--model", metavar="NAME_OR_TOML",
                        help="model with the unknown parameters, values and all (default: the traces' "
                             "structure's topology, never its values)")
    parser.add_argument("--prior", metavar="MODEL_OR_JSON",
                        help="starting model of updating and perturbation: a built-in name or TOML model, or a "
                             "prior.json or results file (e.g. a baseline's results/updating.json) whose parameter "
                             "values are set on the structure (default: the campaign's [prior], DIR/prior.json, "
                             "else the structure's '-postulated' variant)")
    parser.add_argument("--group", action="append", metavar="NAME",
                        help="only this test group (repeatable; default: every group)")
    parser.add_argument("--test", action="append", metavar="PATTERN",
                        help="only tests whose name matches (shell pattern, repeatable; e.g. exact-01)")
    parser.add_argument("--joint", action="store_true", help="identify the selected groups of a repetition together")
    parser.add_argument("--tag", help="result file results/<method>-<tag>.json")
    parser.add_argument("--json", action="store_true", help="print the result document as JSON")
    parser.add_argument("--jobs", type=int, metavar="N",
                        help="processes identifying runs in parallel (default: one per available core; "
                             "1: in this process); the results do not depend on it")
    parser.add_argument("--option", action="append", default=[], metavar="KEY=VALUE",
                        help="a method option by name, for any method including plugins (repeatable; "
                             "VALUE parsed as JSON when it is, else a string), e.g. --option modes=3")
    ls, pt, ry = "least-squares", "perturbation", "rayleigh"
    group = parser.add_argument_group(ls)
    group.add_argument("--estimator", choices=_choices(ls, "estimator"),
                       help="bias-compensated: every channel's noise compensated, calibrated standard errors "
                            "(default); ols: the dissertation's least squares")
    group.add_argument("--samples", type=int, metavar="M",
                       help="sample times per trace (default: every sample)")
    group.add_argument("--interval", type=float, metavar="S",
                       help=f"with --samples: t_k = t_0 + interval k, s (default {_default(ls, 'interval')})")
    group.add_argument("--integration", choices=_choices(ls, "integration"),
                       help="displacements and velocities: measured when logged (auto), else integrated")
    group.add_argument("--weighting", choices=_choices(ls, "weighting"),
                       help="generalised least squares with the declared sensor noise (default) or plain")
    group = parser.add_argument_group(pt)
    group.add_argument("--max-iterations", type=int, metavar="N",
                       help=f"default {_default(pt, 'max_iterations')}")
    group.add_argument("--tol", type=float, help=f"converged when max |dp/p| < tol (default {_default(pt, 'tol')})")
    group.add_argument("--natural-frequencies", action="store_true", default=None,
                       help="add the natural frequencies found in the free vibration (not in the dissertation)")
    group = parser.add_argument_group(ry)
    group.add_argument("--variant", choices=_choices(ry, "variant"),
                       help="displacement/velocity or velocity/acceleration correlations (default auto)")
    group.add_argument("--window", choices=_choices(ry, "window"),
                       help="taper of the time averages (default hann)")
    group.add_argument("--admissible", choices=["cosine"], help="admissible functions with FE interpolation")
    group.add_argument("--functions", type=int, metavar="K", help="number of admissible functions (default: sensors)")
    md = "modal"
    group = parser.add_argument_group(md)
    group.add_argument("--quantity", choices=_choices(md, "quantity"),
                       help="sensors used: displacement, else velocity, else acceleration (default auto)")
    group.add_argument("--block-rows", type=int, metavar="P",
                       help="block rows of the covariance Hankel matrix (default from the data: up to 4000 / row channels, record length / 25)")
    group.add_argument("--max-order", type=int, metavar="N",
                       help=f"highest model order of the stabilisation diagram (default {_default(md, 'max_order')})")
    group.add_argument("--references", type=int, metavar="R",
                       help=f"reference channels (default {_default(md, 'references')})")
    group.add_argument("--segments", type=int, metavar="G",
                       help=f"sample groups of the jackknife errors (default {_default(md, 'segments')})")
    group.add_argument("--min-fraction", type=float, metavar="F",
                       help=f"share of the orders a mode must be stable in (default {_default(md, 'min_fraction')})")
    group.add_argument("--refine", choices=_choices(md, "refine"),
                       help="auto: fit free responses whole to split close pairs of modes (default auto)")
    group.add_argument("--uncertainty", choices=_choices(md, "uncertainty"),
                       help="jackknife: standard errors of frequencies and damping ratios; off: none, "
                            "about half the time (default jackknife)")


def generic(items: list[str]) -> dict[str, Any]:
    """``--option KEY=VALUE`` pairs; VALUE as JSON when it parses, else the string."""
    out = {}
    for item in items:
        key, sep, text = item.partition("=")
        if not sep or not key.strip():
            raise api.UserError(f"{item!r} is not KEY=VALUE", field="--option")
        try:
            out[key.strip().replace("-", "_")] = json.loads(text)
        except json.JSONDecodeError:
            out[key.strip().replace("-", "_")] = text
    return out


def options(args: argparse.Namespace) -> dict[str, Any]:
    """The chosen method's options given on the command line (its own flags,
    then ``--option``)."""
    flags = {k: getattr(args, k) for k in api.methods()[args.method].defaults if getattr(args, k, None) is not None}
    return flags | generic(args.option)


def table(run: dict[str, Any]) -> list[str]:
    """Human-readable lines of one run (a dict of docs/results-format.md)."""
    tests = run["tests"]
    head = (f"repetition {run['repetition']} ({', '.join(tests[:3])}{', ...' if len(tests) > 3 else ''}): "
            f"{run['status']}" + (f" after {run['iterations']} iterations" if run.get("iterations") is not None
                                  else ""))
    lines = [head + (f" - {run['message']}" if run.get("message") else "")]
    for p in run.get("parameters", []):
        err = f" +- {p['std_error']:.3g}" if p.get("std_error") is not None else ""
        start = f"   (from {p['initial']:.6g})" if p.get("initial") is not None else ""
        lines.append(f"  {p['label']:16s} {p['value']:14.6g}{err:14s} {p['unit']}{start}")
    damping, se = run.get("damping") or [], run.get("omega_std") or []
    for i, (w, lam) in enumerate(zip(run.get("omega", []), run.get("eigenvalues", [])), start=1):
        extra = (f"   zeta = {damping[i - 1]:8.5f} +- {run['damping_std'][i - 1]:.2g}"
                 f"   MPC {run['mpc'][i - 1]:.3f}" if damping else "")
        sigma = f" +- {se[i - 1]:.2g}" if damping else ""
        lines.append(f"  mode {i:2d}  omega = {w:10.6f}{sigma} rad/s   omega^2 = {lam:10.6f}{extra}")
    return lines


def run(args: argparse.Namespace) -> int:
    shown = bar(None, "run", args.method) if interactive() else None

    def progress(done: int, total: int) -> None:
        shown.total, shown.n = total, done
        shown.refresh()

    try:
        document = api.identify(args.campaign_dir, args.method, model=args.model, prior=args.prior,
                                groups=args.group, tests=args.test, joint=args.joint, tag=args.tag,
                                progress=progress if shown is not None else None, jobs=args.jobs,
                                **options(args))
    finally:
        if shown is not None:
            shown.close()
    if args.json:
        print(json.dumps(document, indent=1))
        return 0
    runs = document["runs"]
    print(f"{args.method}: {len(runs)} run(s) of {document['model']} -> "
          f"{api.results_file(args.campaign_dir, args.method, args.tag)}")
    for i, result in enumerate(runs):
        print("\n".join(table(result) if i == 0 else table(result)[:1]))
    for line in method_warnings(runs):
        print(line)
    return 0


def method_warnings(runs: list[dict[str, Any]]) -> list[str]:
    """The methods' warnings (``details.warnings``), each once, with the runs it came from when not all."""
    seen: dict[str, int] = {}
    for result in runs:
        for text in dict.fromkeys((result.get("details") or {}).get("warnings") or []):
            seen[text] = seen.get(text, 0) + 1
    return [f"WARNING{'' if n == len(runs) else f' ({n} of {len(runs)} runs)'}: {text}" for text, n in seen.items()]
