"""The reproduction report: ``OUT/report.md`` with PNG figures beside it."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from structbench.identifier.io.results import read_results
from structbench.models import load_model

from . import beyond_modal, plots
from .reproduce import PUBLISHED, STEPS
from .truth_checks import read_truth

UNITS = {"mass": "kg/m", "stiffness": "N/m"}


def _by_kind(labels: list[str], values: np.ndarray) -> dict[str, np.ndarray]:
    """Split a (..., n_par) array by the kind in the labels ``kind[element]``."""
    kinds = [label.split("[")[0] for label in labels]
    return {k: values[..., [i for i, kk in enumerate(kinds) if kk == k]] for k in dict.fromkeys(kinds)}


def ch3_figure(out: Path, tag: str) -> Path:
    folder = out / "ch3"
    _, runs = read_results(folder / "results" / f"least-squares-{tag}.json")
    labels = runs[0].labels()
    table = {p["label"]: p["value"] for p in read_truth(folder / "truth.json")["parameters"]}
    truth = _by_kind(labels, np.array([table[label] for label in labels]))
    estimates = _by_kind(labels, np.array([r.values() for r in runs]))
    return plots.parameter_distribution(out / f"ch3-parameters-{tag}.png",
                                        f"Chapter 3, {tag}: identified vs true ({len(runs)} noise realisations)",
                                        truth, estimates, UNITS)


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


def _shapes(folder: Path, stem: str) -> tuple[np.ndarray, np.ndarray]:
    """Identified shapes of run 0 and the true ones at the same sensors, (n_s, n_modes)."""
    _, runs = read_results(folder / "results" / f"{stem}.json")
    run = runs[0]
    truth = read_truth(folder / "truth.json")
    rows = {tuple(d): i for i, d in enumerate(truth["sensor_dofs"])}
    pick = [rows[(int(c.split("_")[1]), c.split("_", 2)[2])] for c in run.sensors]
    ident = np.array(run.mode_shapes).T
    return ident, np.array(truth["mode_shapes"])[pick][:, :ident.shape[1]]


def _diagrams(out: Path) -> list[Path]:
    """The first stabilisation diagram of every modal results file."""
    return sorted(p for p in out.glob("*/results/modal-*-stabilisation-00.png"))


def modal_figures(out: Path) -> list[Path]:
    """Identified (SSI-cov) vs true beam shapes of the noisy ch5 record, modes 1-10."""
    beam = load_model("ch5-simply-supported-beam")
    ident, true = _shapes(out / "ch5-beam", "modal-noisy")
    x_fine = np.linspace(0, 10, 400)
    return [plots.beam_mode_shapes(out / "ch5-beam-modes-modal.png",
                                   "ch5 beam, 2 % noise: modal method (o) vs true mode shapes, modes 1-10",
                                   beam.points, ident[:, :10], true[:, :10], x_fine,
                                   beam.shape_function(x_fine)[:, :10])]


def ch5_figures(out: Path) -> list[Path]:
    beam = load_model("ch5-simply-supported-beam")
    ident, true = _shapes(out / "ch5-beam", "rayleigh-hann")
    x_fine = np.linspace(0, 10, 400)
    figs = [plots.beam_mode_shapes(out / "ch5-beam-modes.png",
                                   "Chapter 5 beam: identified (o) vs true mode shapes (cf. Figures 5.1, 5.2)",
                                   beam.points, ident[:, :10], true[:, :10], x_fine,
                                   beam.shape_function(x_fine)[:, :10])]
    membrane = load_model("ch5-membrane")
    xy = np.array([membrane.nodes[n][:2] for n, _ in membrane.dofs])
    for tag in ("single", "joint"):
        ident, true = _shapes(out / "ch5-membrane", f"rayleigh-{tag}")
        figs.append(plots.membrane_mode_shapes(out / f"ch5-membrane-modes-{tag}.png",
                                               f"Chapter 5 membrane ({tag}): five lowest modes (cf. Figure 5.4)",
                                               xy, ident[:, :5], true[:, :5]))
    return figs


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


def _beyond_section(out: Path, summary: dict[str, Any]) -> tuple[list[str], Path]:
    """Table of the "beyond the dissertation" rows and the coverage figure."""
    rows = summary["ch3-beyond"]
    lines = ["## Beyond the dissertation: every sample, bias-compensated least squares", "",
             "Medians over the noise seeds; per kind the median |relative error| (worst parameter's",
             "median in brackets) and the coverage of the stated 95 % intervals (calibrated: about",
             "0.95; with few seeds a coarse figure, since one seed moves all parameters of a run",
             "together: benchmarks/least_squares_accuracy.py and tests/test_identify_bias_compensated.py",
             "check it over more).", "",
             "| case | set-up | RMS median (p10-p90) | per kind: error, coverage |", "|---|---|---|---|"]
    for key, r in rows.items():
        campaign, stem = key.split("/")
        kinds = "; ".join(f"{k} {100 * v['median_abs_error']:.2f} % ({100 * v['worst_median_abs_error']:.2f} %)"
                          + (f", {v['coverage95']:.2f}" if "coverage95" in v else "") for k, v in r["kinds"].items())
        lines.append(f"| {campaign} `{stem}` | {_what(campaign, stem.removeprefix('least-squares-'))} | "
                     f"{r['rms']['median']:.4f} ({r['rms']['p10']:.4f}-{r['rms']['p90']:.4f}) | {kinds} |")
    figure = plots.coverage(out / "ch3-coverage.png", "Chapter 3: coverage of the stated 95 % intervals",
                            {key: {k: v["coverage95"] for k, v in r["kinds"].items() if "coverage95" in v}
                             for key, r in rows.items()})
    return lines, figure


def write_report(out: Path, summary: dict[str, Any], scores: dict[str, Any]) -> Path:
    """Write ``out/report.md`` and its figures; returns the report's path."""
    figures = [ch3_figure(out, "m4"), ch3_figure(out, "m8"), ch4_figure(out, scores), *ch5_figures(out),
               *modal_figures(out)]
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
