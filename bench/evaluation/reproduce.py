"""The dissertation end to end: every case through FMUs, the harness, trace
files, the identifiers and scoring, beside the dissertation's own figures.

Each campaign of ``campaigns/`` runs into ``OUT/<campaign>/``; each
identification (:data:`STEPS`) writes ``results/<method>-<tag>.json`` there;
:func:`summarize` condenses the scores into the keys of ``structbench
reproduce --json``.
"""
from __future__ import annotations

import dataclasses
from importlib import resources
import sys
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from structbench.models.errors import UserError

from structbench.harness.campaign import Campaign, load_campaign
from structbench.harness.run import run_campaign
from structbench.dispatch.runs import identify_folder

from . import beyond_modal
from .beyond_least_squares import beyond
from .metrics import frequency_error_pct
from .scores import score_campaign

CAMPAIGNS = Path(str(resources.files("structbench.campaigns")))
NAMES = ("ch3", "ch3-damped", "ch4-case1", "ch4-case2", "ch5-beam", "ch5-membrane", "ch5-damped")

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


@dataclass(frozen=True)
class Step:
    """One identification: campaign, results tag, method, the test groups and
    tests (patterns) it reads, ``joint`` runs and method ``options``;
    ``variant`` says what it is in the report."""

    campaign: str
    tag: str
    method: str
    variant: str
    groups: tuple[str, ...] = ()
    tests: tuple[str, ...] = ()
    joint: bool = False
    options: Mapping[str, Any] = field(default_factory=dict)

    @property
    def stem(self) -> str:
        return f"{self.method}-{self.tag}"


LS, PT, RY, MD = "least-squares", "perturbation", "rayleigh", "modal"
STEPS: tuple[Step, ...] = (
    Step('ch3', 'm4', LS,
         'measured u, v; noise-weighted least squares (the headline ch3-m4)',
         groups=('harmonic',), options={'estimator': 'ols', 'interval': 0.5, 'samples': 4}),
    Step('ch3', 'm8', LS,
         'measured u, v; noise-weighted least squares (the headline ch3-m8)',
         groups=('harmonic',), options={'estimator': 'ols', 'interval': 0.5, 'samples': 8}),
    Step('ch3', 'm4-plain', LS,
         'measured u, v; plain least squares as in the dissertation',
         groups=('harmonic',), options={'estimator': 'ols', 'interval': 0.5, 'samples': 4, 'weighting': 'none'}),
    Step('ch3', 'm8-plain', LS,
         'measured u, v; plain least squares as in the dissertation',
         groups=('harmonic',), options={'estimator': 'ols', 'interval': 0.5, 'samples': 8, 'weighting': 'none'}),
    Step('ch3', 'm8-integrated', LS,
         'u, v integrated from the noisy 1 ms accelerations (hold-aware Simpson)',
         groups=('harmonic',),
         options={'estimator': 'ols', 'interval': 0.5, 'samples': 8, 'integration': 'zoh-simpson'}),
    Step('ch3', 'm8-trapezoid', LS,
         'u, v integrated from the noisy 1 ms accelerations (trapezoidal rule)',
         groups=('harmonic',), options={'estimator': 'ols', 'interval': 0.5, 'samples': 8, 'integration': 'trapezoid'}),
    Step('ch3', 'm8-noisy-displacement', LS,
         '2 % noise on the displacement and velocity sensors too',
         groups=('noisy-displacement',), options={'estimator': 'ols', 'interval': 0.5, 'samples': 8}),
    Step('ch3', 'all', LS,
         'beyond the dissertation: every sample, bias-compensated least squares whitened by the sensor noise',
         groups=('harmonic',)),
    Step('ch3', 'all-noisy-displacement', LS,
         'beyond the dissertation: every sample, bias-compensated, whitened; 2 % noise on every sensor',
         groups=('noisy-displacement',)),
    Step('ch3-damped', 'm8', LS,
         "the dissertation's set-up: 8 sample times, noise-weighted least squares",
         groups=('harmonic',), options={'estimator': 'ols', 'interval': 0.5, 'samples': 8}),
    Step('ch3-damped', 'all', LS,
         'beyond the dissertation: every sample, bias-compensated least squares whitened by the sensor noise',
         groups=('harmonic',)),
    Step('ch4-case1', 'case1', PT,
         "noise-free, all 12 DOF at 0.5 rad/s; the dissertation's method",
         groups=('exact',), tests=('exact-01',)),
    Step('ch4-case1', 'case1-noisy', PT,
         'noisy; with natural-frequency equations from the free vibration (not in the dissertation)',
         groups=('noisy',), tests=('noisy-01',), options={'natural_frequencies': True}),
    Step('ch4-case1', 'case1-noisy-plain', PT,
         "noisy; the dissertation's method alone",
         groups=('noisy',), tests=('noisy-01',)),
    Step('ch4-case2', 'case2', PT,
         'noise-free, one tip sensor, 12 frequencies; with natural-frequency equations',
         groups=('exact',), options={'natural_frequencies': True}),
    Step('ch4-case2', 'case2-plain', PT,
         "noise-free, one tip sensor; the dissertation's method alone",
         groups=('exact',)),
    Step('ch4-case2', 'case2-noisy', PT,
         'noisy; with natural-frequency equations',
         groups=('noisy',), options={'natural_frequencies': True}),
    Step('ch5-beam', 'hann', RY,
         'T = 100 s, Hann-tapered correlations (the headline)',
         groups=('impulse',)),
    Step('ch5-beam', 'plain', RY,
         'T = 100 s, plain correlations',
         groups=('impulse',), options={'window': 'rectangular'}),
    Step('ch5-beam', 'long-plain', RY,
         'T = 1200 s, plain correlations',
         groups=('impulse-long',), options={'window': 'rectangular'}),
    Step('ch5-membrane', 'single', RY,
         "one record, 1 m/s at node 5, cosine admissible functions (the dissertation's set-up)",
         groups=('initial-velocity',), options={'admissible': 'cosine'}),
    Step('ch5-membrane', 'joint', RY,
         'records started at nodes 5 and 6 together, cosine admissible functions (the headline; not in the '
         'dissertation)',
         joint=True, options={'admissible': 'cosine'}),
    # beyond the dissertation (bench/evaluation/beyond_modal.py): the modal method beside the Rayleigh quotient
    Step('ch5-beam', 'noisy', RY,
         'T = 100 s, 2 % noise on every sensor, Hann-tapered correlations',
         groups=('impulse-noisy',)),
    Step('ch5-beam', 'noisy', MD,
         'T = 100 s, 2 % noise on every sensor, SSI-cov',
         groups=('impulse-noisy',)),
    Step('ch5-membrane', 'single', MD,
         'one record, 1 m/s at node 5, SSI-cov',
         groups=('initial-velocity',)),
    Step('ch5-membrane', 'joint', MD,
         'records started at nodes 5 and 6 together, SSI-cov',
         joint=True),
    Step('ch5-damped', 'impulse', RY,
         'damped beam, impulse, 2 % noise; Hann-tapered correlations',
         groups=('impulse',)),
    Step('ch5-damped', 'impulse', MD,
         'damped beam, impulse, 2 % noise; SSI-cov on the velocities',
         groups=('impulse',), options={'quantity': 'velocity'}),
    Step('ch5-damped', 'random', MD,
         'damped beam, 8 h of unmeasured ambient force (new each repetition), 2 % noise; SSI-cov on the velocities',
         groups=('random',), options={'quantity': 'velocity'}),
)


def campaign_with_repetitions(path: Path, repetitions: int | None) -> Campaign:
    """Load a campaign; tests with Monte Carlo repetitions get ``repetitions``."""
    campaign = load_campaign(path)
    if repetitions is None:
        return campaign
    if repetitions < 1:
        raise UserError("must be at least 1", field="--repetitions")
    tests = tuple(dataclasses.replace(t, repetitions=repetitions) if t.repetitions > 1 else t
                  for t in campaign.tests)
    return dataclasses.replace(campaign, tests=tests)


def run_all(out: Path, repetitions: int | None, jobs: int | None,
            say: Callable[[str], None]) -> dict[str, dict[str, Any]]:
    """Run every campaign and identification; returns scores per campaign."""
    missing = [n for n in NAMES if not (CAMPAIGNS / f"{n}.toml").is_file()]
    if missing:
        raise UserError(f"campaign files {missing} not found in {CAMPAIGNS} (a broken installation)",
                        field="campaigns")
    fmu_dir = out / "fmus"
    scores = {}
    for i, name in enumerate(NAMES, start=1):
        folder = out / name
        say(f"[{i}/{len(NAMES)}] {name}: simulating through the FMU")
        status = run_campaign(campaign_with_repetitions(CAMPAIGNS / f"{name}.toml", repetitions), folder,
                              jobs=jobs, fmu_dir=fmu_dir)
        if status.failed:
            raise UserError(f"{status.failed} test(s) failed; see {folder / 'status.json'}", field=name)
        for step in (s for s in STEPS if s.campaign == name):
            say(f"      identify {step.stem}: {step.variant}")
            identify_folder(folder, step.method, groups=step.groups or None, tests=step.tests or None,
                            joint=step.joint, tag=step.tag, options=step.options,
                            jobs=None if jobs is None else max(1, jobs))
        scores[name] = score_campaign(folder)
    return scores


def _s(summary: dict[str, Any], key: str) -> float:
    return summary[key]["median"]


def summarize(scores: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """The ``reproduce --json`` document: one entry per dissertation case."""
    out: dict[str, Any] = {}
    ch3 = scores["ch3"]
    for m in ("m4", "m8"):
        s = ch3[f"least-squares-{m}"]["summary"]
        out[f"ch3-{m}"] = {"rms": _s(s, "rms"), "rms_p10": s["rms"]["p10"], "rms_p90": s["rms"]["p90"],
                           "freq_error_pct": s["freq_error_pct_median"], "repetitions": s["runs"],
                           "variants": {step.tag: _variant(ch3[step.stem]["summary"], step)
                                        for step in STEPS if step.campaign == "ch3" and m in step.tag}}
    out["ch3-beyond"] = beyond(scores)
    for case in ("case1", "case2"):
        camp = scores[f"ch4-{case}"]
        run = camp[f"perturbation-{case}"]["runs"][0]
        plain = camp[f"perturbation-{case}-plain"]["runs"][0] if f"perturbation-{case}-plain" in camp else None
        out[f"ch4-{case}"] = {"rms": run["rms"], "iterations": run["iterations"], "status": run["status"],
                              "rms_history": run["rms_history"],
                              "natural_frequency_equations": case == "case2"}
        if plain is not None:
            out[f"ch4-{case}"]["dissertation_method"] = {"status": plain["status"], "rms": plain["rms"]}
        noisy = camp[f"perturbation-{case}-noisy"]["summary"]
        out[f"ch4-{case}-noisy"] = {"rms_initial": _s(noisy, "rms_initial"), "rms": _s(noisy, "rms"),
                                    "rms_p10": noisy["rms"]["p10"], "rms_p90": noisy["rms"]["p90"],
                                    "improved_fraction": noisy["improved_fraction"],
                                    "repetitions": noisy["runs"], "natural_frequency_equations": True}
        if f"perturbation-{case}-noisy-plain" in camp:
            p = camp[f"perturbation-{case}-noisy-plain"]["summary"]
            out[f"ch4-{case}-noisy"]["dissertation_method"] = {"rms": _s(p, "rms"),
                                                              "improved_fraction": p["improved_fraction"]}
    beam = scores["ch5-beam"]
    out["ch5-beam"] = _modes(beam["rayleigh-hann"]["summary"], 10) | {
        "variants": {t: _modes(beam[f"rayleigh-{t}"]["summary"], 10) for t in ("plain", "long-plain")}}
    mem = scores["ch5-membrane"]
    out["ch5-membrane"] = _modes(mem["rayleigh-joint"]["summary"], 5, squared=True) | {
        "variants": {"single": _modes(mem["rayleigh-single"]["summary"], 5, squared=True)}}
    out["ch5-beyond"] = beyond_modal.summarize(scores)
    return out


def _variant(summary: dict[str, Any], step: Step) -> dict[str, Any]:
    return {"what": step.variant, "rms": _s(summary, "rms"), "rms_p90": summary["rms"]["p90"]}


def _modes(summary: dict[str, Any], count: int, squared: bool = False) -> dict[str, Any]:
    omega = np.asarray(summary["omega_median"][:count])
    out = {"omega": omega.tolist(), "freq_error_pct": summary["freq_error_pct_median"][:count],
           "mac": summary.get("mac_median", [])[:count]}
    if squared:
        out["lambda"] = (omega**2).tolist()
        out["lambda_error_pct"] = frequency_error_pct(omega**2, np.asarray(summary["omega_true"][:count]) ** 2).tolist()
    return out


def stderr(message: str) -> None:
    print(message, file=sys.stderr, flush=True)
