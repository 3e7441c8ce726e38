"""The reproduction's "beyond the dissertation" rows: the modal method
(SSI-cov, damping and errors) beside the dissertation's Rayleigh quotient on
the same traces: the ch5 beam with 2 % sensor noise, the membrane (one
record and two), and the damped ch5 campaign (impulse and unmeasured random
force, 2 % noise on every sensor)."""
from __future__ import annotations

from typing import Any

ROWS = (  # key, campaign, results stem, modes (1-based) shown
    ("ch5-beam-noisy/rayleigh", "ch5-beam", "rayleigh-noisy", list(range(1, 11))),
    ("ch5-beam-noisy/modal", "ch5-beam", "modal-noisy", list(range(1, 16))),
    ("ch5-membrane-single/rayleigh", "ch5-membrane", "rayleigh-single", list(range(1, 6))),
    ("ch5-membrane-single/modal", "ch5-membrane", "modal-single", list(range(2, 7))),
    ("ch5-membrane-joint/rayleigh", "ch5-membrane", "rayleigh-joint", list(range(1, 6))),
    ("ch5-membrane-joint/modal", "ch5-membrane", "modal-joint", list(range(2, 7))),
    ("ch5-damped-impulse/rayleigh", "ch5-damped", "rayleigh-impulse", list(range(1, 11))),
    ("ch5-damped-impulse/modal", "ch5-damped", "modal-impulse", list(range(1, 16))),
    ("ch5-damped-random/modal", "ch5-damped", "modal-random", list(range(1, 16))),
)


def _pick(values: list[float] | None, modes: list[int]) -> list[float]:
    return [values[m - 1] if values and m - 1 < len(values) else float("nan") for m in modes]


def summarize(scores: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """Per row: the modes shown, median frequency errors (%), MAC, and for the
    modal method median damping errors (% of the true ratio), the share of runs
    that found each mode and the coverage of its stated 95 % intervals."""
    out: dict[str, Any] = {}
    for key, campaign, stem, modes in ROWS:
        summary = scores[campaign][stem]["summary"]
        row = {"modes": modes, "runs": summary["runs"],
               "freq_error_pct": _pick(summary.get("freq_error_pct_median"), modes),
               "mac": _pick(summary.get("mac_median"), modes)}
        if "damping_error_pct_median" in summary:
            row |= {"damping_error_pct": _pick(summary["damping_error_pct_median"], modes),
                    "found_fraction": _pick(summary["found_fraction"], modes),
                    "omega_coverage": _pick(summary["omega_coverage"], modes),
                    "zeta_coverage": _pick(summary["zeta_coverage"], modes),
                    "extra_modes": summary["extra_modes_median"]}
        out[key] = row
    return out


def _fmt(values: list[float], fmt: str) -> str:
    return ", ".join("-" if v != v else fmt.format(v) for v in values)


def section(beyond: dict[str, Any]) -> list[str]:
    """Markdown lines of the rows (medians over the runs; '-' = not found or not applicable)."""
    lines = ["## Beyond the dissertation: the modal method (SSI-cov) beside the Rayleigh quotient", "",
             "Same traces for both methods; medians over the runs. Modes are numbered as in the truth",
             "(the membrane's mode 1 is its rigid-body mode, which the modal method does not report).",
             "'-': not found, or no true damping ratio.", "",
             "| row | runs | modes | frequency error (%) | MAC | damping error (%) | found | 95 % coverage (omega / zeta) |",
             "|---|---|---|---|---|---|---|---|"]
    for key, row in beyond.items():
        damping = _fmt(row.get("damping_error_pct", []), "{:+.1f}") or "n/a"
        found = _fmt(row.get("found_fraction", []), "{:.2f}") or "n/a"
        cover = (f"{_fmt(row['omega_coverage'], '{:.2f}')} / {_fmt(row['zeta_coverage'], '{:.2f}')}"
                 if "omega_coverage" in row else "n/a")
        lines.append(f"| {key} | {row['runs']} | {row['modes'][0]}-{row['modes'][-1]} | "
                     f"{_fmt(row['freq_error_pct'], '{:+.3f}')} | {_fmt(row['mac'], '{:.3f}')} | {damping} | "
                     f"{found} | {cover} |")
    return lines
