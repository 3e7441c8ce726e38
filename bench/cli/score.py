"""``structbench score``: compare a campaign's results with its truth.

The text output says what ``--json`` holds in short: parameter errors (for
least squares with 5 runs or more, the median efficiency: Cramer-Rao bound /
achieved spread, ``summary.efficiency``), and
for modal results (modes paired with the true ones) a table of the true
modes with how often each was found, the median frequency and damping
errors, the coverage of the stated standard errors and the MAC; modes never
found read ``not found``, modes found beyond the true ones are counted as
invented.
"""
from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

from structbench import api

HELP = "score results/*.json of a campaign folder against truth.json"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("campaign_dir", type=Path, metavar="CAMPAIGN_DIR")
    parser.add_argument("--json", action="store_true", help="print the scores as JSON")


def _finite(value: Any) -> bool:
    return isinstance(value, (int, float)) and math.isfinite(value)


def _num(value: Any, spec: str, width: int) -> str:
    """``value`` formatted, or ``-`` (no value: unknown truth, no stated error)."""
    return (format(value, spec) if _finite(value) else "-").rjust(width)


def _fmt(values: list[float], digits: int = 2) -> str:
    return " ".join(f"{v:+.{digits}f}" if _finite(v) else "n/a" for v in values)


def _coverage(runs: list[dict[str, Any]], key: str) -> str:
    """Share of (run, mode) pairs whose 95 % interval holds the truth."""
    flags = [v for r in runs for v in r.get(key, []) if _finite(v)]
    return f"{100 * sum(flags) / len(flags):.0f} % of {len(flags)}" if flags else "no stated errors"


def modal_lines(summary: dict[str, Any], runs: list[dict[str, Any]]) -> list[str]:
    """Text lines of modal scores: modes found, missed and invented, coverage
    of the stated errors, then one row per true mode."""
    found = summary["found_fraction"]
    missed = [str(i) for i, f in enumerate(found, start=1) if not f > 0]
    lines = [f"  modes: {len(found) - len(missed)} of {len(found)} true modes found"
             + (f" in some run, missed: mode(s) {', '.join(missed)}" if missed else "")
             + f"; invented (spurious) modes per run: median {summary['extra_modes_median']:g}",
             f"  coverage of the stated standard errors (95 % intervals): frequencies "
             f"{_coverage(runs, 'omega_covered')}, damping ratios {_coverage(runs, 'zeta_covered')}",
             f"  {'mode':>4s} {'omega true':>11s} {'found':>6s} {'freq err %':>11s} {'damp err %':>11s} "
             f"{'omega cov':>9s} {'zeta cov':>9s}" + (f" {'MAC':>6s}" if "mac_median" in summary else "")]
    for i, share in enumerate(found):
        head = f"  {i + 1:4d} {summary['omega_true'][i]:11.5g} {100 * share:4.0f} %"
        if not share > 0:
            lines.append(f"{head} {'not found':>11s}")
            continue
        cover = [_num(100 * summary[key][i], ".0f", 7) + " %" for key in ("omega_coverage", "zeta_coverage")]
        row = (f"{head} {_num(summary['freq_error_pct_median'][i], '+.3f', 11)} "
               f"{_num(summary['damping_error_pct_median'][i], '+.2f', 11)} {' '.join(cover)}")
        lines.append(row + (f" {_num(summary['mac_median'][i], '.3f', 6)}" if "mac_median" in summary else ""))
    return lines


def damage_lines(damage: dict[str, Any]) -> list[str]:
    """Text lines of the damage scores of an updating results file (evaluation/damage_scores.py)."""
    s = damage["summary"]
    lines = [f"  damage (|change| > {s['z_flag']:g} standard errors, change = value / prior - 1):"]
    if "found" in s:
        lines.append(f"    damaged {', '.join(damage['runs'][0]['declared'])} found in {s['found']} of {s['runs']} "
                     f"runs; change error (pp) median "
                     + ", ".join(f"{k} {v:+.2f}" for k, v in s["size_error_pp_median"].items())
                     + "; falsely flagged: "
                     + (", ".join(f"{k} in {v}" for k, v in sorted(s["false_flag_count"].items())) or "none"))
    for i, r in enumerate(damage["runs"][:5]):
        shown = ", ".join(f"{lab} {100 * r['change'][r['labels'].index(lab)]:+.1f} % "
                          f"(+- {100 * r['change_std'][r['labels'].index(lab)]:.1f})" for lab in r["flagged"])
        lines.append(f"    run {i}: flagged {shown or 'none'}")
    return lines


def efficiency_lines(eff: dict[str, Any]) -> list[str]:
    """Text lines of ``summary.efficiency`` (evaluation/efficiency.py): the
    median efficiency (Cramer-Rao bound / achieved spread) with its range,
    what the bound is, then the parameters farthest from the bound."""
    head = f"  spread over {eff['runs']} runs against the Cramer-Rao bound"
    if eff.get("reason") or eff.get("median") is None:
        return [f"{head}: {eff.get('reason', 'no finite efficiency')}"]
    out = [f"{head}: efficiency (bound / achieved std, 1 at best) median {eff['median']:.3f} "
           f"(range {eff['min']:.3f} .. {eff['max']:.3f}, 10-90 %: {eff['p10']:.3f} .. {eff['p90']:.3f})",
           f"    bound: {eff['bound']}"]
    bounded = [p for p in eff["parameters"] if p["efficiency"] is not None]  # null: no bound (undetermined)
    worst = sorted(bounded, key=lambda p: p["efficiency"] if _finite(p["efficiency"]) else -1)[:3]
    out.append("    lowest: " + ", ".join(f"{p['label']} {_num(p['efficiency'], '.3f', 0)} (achieved "
                                          f"{p['achieved_std']:.3g}, bound {p['bound_std']:.3g})" for p in worst))
    return out


def lines(stem: str, score: dict[str, Any]) -> list[str]:
    """Text lines of one results file's scores."""
    s = score["summary"]
    out = [f"{stem} ({score['method']}, {s['runs']} run(s))"]
    if "rms" in s:
        out.append(f"  normalized RMS parameter error: median {s['rms']['median']:.4g} "
                   f"(10-90 %: {s['rms']['p10']:.4g} .. {s['rms']['p90']:.4g})")
    if "efficiency" in s:  # least squares: achieved spread against the Cramer-Rao bound
        out += efficiency_lines(s["efficiency"])
    if "rms_initial" in s:
        out.append(f"  starting model: median {s['rms_initial']['median']:.4g}; improved in "
                   f"{100 * s['improved_fraction']:.0f} % of runs; iterations {s['iterations']}")
    if "damage" in score:  # updating from a baseline's results: what changed (evaluation/damage_scores.py)
        out += damage_lines(score["damage"])
    if "found_fraction" in s:  # modal results, modes paired with the true ones
        return out + modal_lines(s, score["runs"])
    if s.get("freq_error_pct_median"):
        out.append(f"  frequency error (%), median per mode: {_fmt(s['freq_error_pct_median'])}")
    if s.get("mac_median"):
        out.append(f"  MAC, median per mode: {' '.join(f'{v:.3f}' for v in s['mac_median'])}")
    return out


def run(args: argparse.Namespace) -> int:
    scores = api.score(args.campaign_dir)
    if args.json:
        print(json.dumps(scores, indent=1))
        return 0
    for stem, score in scores.items():
        print("\n".join(lines(stem, score)))
    return 0
