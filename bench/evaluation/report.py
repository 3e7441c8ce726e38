"""The reproduction report: ``OUT/report.md`` with PNG figures beside it."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from . import beyond_modal, plots
from .steps import STEPS

# The dissertation's figures (shared/reference/dissertation-cases.md).
PUBLISHED: dict[str, dict[str, Any]] = {
    "ch3-m4": {"rms": 0.0284, "rms_printed": 0.056, "freq_error_pct_max": 0.6},
    "ch3-m8": {"rms": 0.0183, "rms_printed": 0.035, "freq_error_pct_max": 0.6},
    "ch4-case1": {"rms_initial": 0.122, "rms": 0.0, "iterations": 5},
    "ch4-case2": {"rms_initial": 0.0293, "rms": 0.0, "iterations": 5},
    "ch4-case1-noisy": {"rms_initial": 0.122, "note": "improves on the postulated model (plotted values lost)"},
    "ch4-case2-noisy": {"rms_initial": 0.0293, "note": "improves on the postulated model (plotted values lost)"},
    "ch5-beam": {"omega": [0.09834, 0.39433, 0.88821, 1.57910, 2.46734, 3.55311, 6.68212, 8.49410,
                           10.19992, 11.46529],
                 "freq_error_pct": [-0.4, -0.1, 0.0, 0.0, 0.0, 0.0, 38.2, 34.5, 27.6, 16.2]},
    "ch5-membrane": {"lambda": [0.0, 1.1835, 1.1948, 2.7669, 5.8482],
                     "lambda_error_pct": [0.0, -0.6, 0.3, 0.1, 0.1]},
}


def ch4_figure(out: Path, scores: dict[str, Any]) -> Path:
    histories = {}
    for case in ("case1", "case2"):
        camp = scores[f"ch4-{case}"]
        histories[f"{case} noise-free"] = np.array(camp[f"perturbation-{case}"]["runs"][0]["rms_history"])
        noisy = [r["rms_history"] for r in camp[f"perturbation-{case}-noisy"]["runs"]]
        width = max(len(h) for h in noisy)
        histories[f"{case} noisy"] = np.array([h + [h[-1]] * (width - len(h)) for h in noisy])
    return plots.rms_history(out / "ch4-rms-history.png",
                             "Chapter 4: normalized RMS error vs iteration (cf. Figures 4.2-4.5)", histories)


def _diagrams(out: Path) -> list[Path]:
    """The first stabilisation diagram of every modal results file."""
    return sorted(p for p in out.glob("*/results/modal-*-stabilisation-00.png"))


def _row(values: list[float], fmt: str = "{:.4g}") -> str:
    return ", ".join(fmt.format(v) for v in values)


def table_rows(summary: dict[str, Any]) -> list[tuple[str, str, str]]:
    """(case, dissertation, this run) rows of the headline table."""
    rows = []
    for m in ("m4", "m8"):
        s, p = summary[f"ch3-{m}"], PUBLISHED[f"ch3-{m}"]
        rows.append((f"ch3-{m} normalized RMS", f"{p['rms']} (printed {p['rms_printed']})",
                     f"{s['rms']:.4f} median, p90 {s['rms_p90']:.4f} ({s['repetitions']} seeds)"))
        worst = max(abs(v) for v in s["freq_error_pct"][2:])
        rows.append((f"ch3-{m} frequency error, modes 3-10", f"< {p['freq_error_pct_max']} %", f"< {worst:.2f} %"))
    for case in ("case1", "case2"):
        s, p = summary[f"ch4-{case}"], PUBLISHED[f"ch4-{case}"]
        extra = " (with natural-frequency equations)" if s["natural_frequency_equations"] else ""
        rows.append((f"ch4-{case} noise-free", f"{p['rms_initial']} -> 0 in {p['iterations']} iterations",
                     f"{s['rms_history'][0]:.4f} -> {s['rms']:.2g} in {s['iterations']} iterations{extra}"))
        n = summary[f"ch4-{case}-noisy"]
        rows.append((f"ch4-{case}-noisy", PUBLISHED[f"ch4-{case}-noisy"]["note"],
                     f"{n['rms_initial']:.4f} -> {n['rms']:.3g} median; improved in "
                     f"{100 * n['improved_fraction']:.0f} % of {n['repetitions']} seeds"))
    b = summary["ch5-beam"]
    rows.append(("ch5-beam omega (rad/s)", _row(PUBLISHED["ch5-beam"]["omega"]), _row(b["omega"])))
    rows.append(("ch5-beam error (%)", _row(PUBLISHED["ch5-beam"]["freq_error_pct"], "{:+.1f}"),
                 _row(b["freq_error_pct"], "{:+.2f}")))
    mem = summary["ch5-membrane"]
    single = mem["variants"]["single"]
    rows.append(("ch5-membrane omega^2 (rad^2/s^2), two records", _row(PUBLISHED["ch5-membrane"]["lambda"]),
                 _row(mem["lambda"])))
    rows.append(("ch5-membrane error in omega^2 (%), two records",
                 _row(PUBLISHED["ch5-membrane"]["lambda_error_pct"], "{:+.1f}"), _row(mem["lambda_error_pct"], "{:+.2f}")))
    rows.append(("ch5-membrane error in omega^2 (%), one record", "(as above)",
                 _row(single["lambda_error_pct"], "{:+.2f}")))
    return rows


def _variants_section(summary: dict[str, Any]) -> list[str]:
    lines = ["## Variants", "", "| case | variant | result |", "|---|---|---|"]
    for m in ("m4", "m8"):
        for tag, v in summary[f"ch3-{m}"]["variants"].items():
            lines.append(f"| ch3 `{tag}` | {v['what']} | RMS {v['rms']:.4f} median, p90 {v['rms_p90']:.4f} |")
    for case in ("case1", "case2"):
        d = summary[f"ch4-{case}"].get("dissertation_method")
        if d:
            lines.append(f"| ch4-{case} | the dissertation's method alone, noise-free | {d['status']}, RMS {d['rms']:.3g} |")
        d = summary[f"ch4-{case}-noisy"].get("dissertation_method")
        if d:
            lines.append(f"| ch4-{case}-noisy | the dissertation's method alone | RMS {d['rms']:.4f} median, "
                         f"improved in {100 * d['improved_fraction']:.0f} % |")
    for tag, v in summary["ch5-beam"]["variants"].items():
        lines.append(f"| ch5-beam `{tag}` | {_what('ch5-beam', tag)} | error (%): {_row(v['freq_error_pct'], '{:+.2f}')} |")
    v = summary["ch5-membrane"]["variants"]["single"]
    lines.append(f"| ch5-membrane `single` | {_what('ch5-membrane', 'single')} | error in omega^2 (%): "
                 f"{_row(v['lambda_error_pct'], '{:+.3f}')} |")
    return lines


def _what(campaign: str, tag: str) -> str:
    return next(s.variant for s in STEPS if s.campaign == campaign and s.tag == tag)


def _efficiency(eff: dict[str, Any] | None) -> str:
    """``median (min-max)`` of a results file's efficiency (evaluation/efficiency.py), ``*`` when
    the bound is for another estimator than the one run; ``-`` when there is none."""
    if not eff or eff.get("median") is None:
        return "-" if not eff else eff.get("reason", "-")
    return (f"{eff['median']:.2f} ({eff['min']:.2f}-{eff['max']:.2f})"
            + ("" if eff["same_settings"] else "*"))


def _rms(x: float) -> str:
    """A normalized RMS: 4 decimals, or 2 significant digits below 0.001."""
    return f"{x:.4f}" if x >= 1e-3 else f"{x:.2g}"


def _beyond_section(out: Path, summary: dict[str, Any]) -> tuple[list[str], Path]:
    """Table of the "beyond the dissertation" rows and the coverage figure."""
    rows = summary["ch3-beyond"]
    lines = ["## Beyond the dissertation: every sample, bias-compensated least squares; model updating from FRFs", "",
             "Medians over the noise seeds; per kind the median |relative error| (worst parameter's",
             "median in brackets) and the coverage of the stated 95 % intervals (calibrated: about",
             "0.95; with few seeds a coarse figure, since one seed moves all parameters of a run",
             "together: benchmarks/least_squares_accuracy.py and tests/test_identify_bias_compensated.py",
             "check it over more).", "",
             "Efficiency: the Cramer-Rao bound (`structbench plan`, the default estimator on the same",
             "samples) over the achieved standard deviation per parameter, median (range) over the",
             "parameters; 1 at best; marked * where the results used another estimator than the bound's.", "",
             "| case | set-up | RMS median (p10-p90) | per kind: error, coverage | efficiency |", "|---|---|---|---|---|"]
    for key, r in rows.items():
        campaign, stem = key.split("/")
        kinds = "; ".join(f"{k} {100 * v['median_abs_error']:.2f} % ({100 * v['worst_median_abs_error']:.2f} %)"
                          + (f", {v['coverage95']:.2f}" if "coverage95" in v else "") for k, v in r["kinds"].items())
        step = next(s for s in STEPS if s.campaign == campaign and s.stem == stem)
        lines.append(f"| {campaign} `{stem}` | {step.variant} | "
                     f"{_rms(r['rms']['median'])} ({_rms(r['rms']['p10'])}-{_rms(r['rms']['p90'])}) | {kinds} | "
                     f"{_efficiency(r.get('efficiency'))} |")
    figure = plots.coverage(out / "ch3-coverage.png", "Chapter 3: coverage of the stated 95 % intervals",
                            {key: {k: v["coverage95"] for k, v in r["kinds"].items() if "coverage95" in v}
                             for key, r in rows.items()})
    return lines, figure


def write_report(out: Path, summary: dict[str, Any], scores: dict[str, Any]) -> Path:
    """Write ``out/report.md`` and its figures; returns the report's path."""
    ch3, beam, membrane = (plots.case_figures(out, name) for name in ("ch3", "ch5-beam", "ch5-membrane"))
    figures = [*ch3, ch4_figure(out, scores), beam[0], *membrane, beam[1]]
    lines = ["# structbench: the dissertation reproduced through FMUs", "",
             "Every figure below comes from FMUs driven by the harness, trace files and the",
             "identifiers; medians and spreads are over Monte Carlo noise realisations.",
             "Frequency errors are (identified - true) / true; the dissertation prints the",
             "opposite sign for Table 5.1. Units: SI (rad/s, kg/m, N/m).", "",
             "| case | dissertation | this run |", "|---|---|---|"]
    lines += [f"| {a} | {b} | {c} |" for a, b, c in table_rows(summary)]
    lines += ["", "Which variant each headline figure comes from:", ""]
    lines += [f"- `{s.campaign}` `{s.tag}`: {s.variant}" for s in STEPS
              if s.tag in ("m4", "m8", "case1", "case2", "case1-noisy", "case2-noisy", "hann", "joint")]
    beyond_lines, coverage_figure = _beyond_section(out, summary)
    figures.append(coverage_figure)
    lines += ["", *_variants_section(summary), "", *beyond_lines, "", *beyond_modal.section(summary["ch5-beyond"]), ""]
    lines += ["Stabilisation diagrams of the modal method (first run of each):", ""]
    lines += [f"![{p.stem}]({p.relative_to(out).as_posix()})" for p in _diagrams(out)]
    lines += ["", "## Figures", ""]
    lines += [f"![{f.stem}]({f.name})" for f in figures]
    path = out / "report.md"
    path.write_text("\n".join(lines) + "\n")
    return path
