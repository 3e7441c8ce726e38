"""The dissertation end to end: every case through FMUs, the harness, trace
files, the identifiers and scoring into ``OUT/<campaign>/`` (the tests an
identification of :data:`STEPS` reads), two cases at a time (:func:`run_all`),
a case's traces deleted once it is scored unless kept; :func:`summarize`
condenses the scores for ``structbench reproduce --json`` (cf. :mod:`.report`).
"""
from __future__ import annotations

import dataclasses
import json
import os
import shutil
import subprocess
import sys
import time
import traceback
from collections import deque
from fnmatch import fnmatch
from importlib import resources
from multiprocessing.connection import Connection, wait
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

import numpy as np

from structbench.models.errors import UserError

from . import beyond_modal
from .beyond_least_squares import beyond
from .metrics import frequency_error_pct
from .steps import STEPS, Step

if TYPE_CHECKING:
    from structbench.harness.campaign import Campaign

CAMPAIGNS = Path(str(resources.files("structbench.campaigns")))
NAMES = ("ch3", "ch3-damped", "ch4-case1", "ch4-case2", "ch5-beam", "ch5-membrane", "ch5-damped")


def campaign_with_repetitions(path: Path, repetitions: int | None) -> Campaign:
    """Load a campaign; tests with Monte Carlo repetitions get ``repetitions``."""
    from structbench.harness.campaign import load_campaign
    campaign = load_campaign(path)
    if repetitions is None:
        return campaign
    if repetitions < 1:
        raise UserError("must be at least 1", field="--repetitions")
    tests = tuple(dataclasses.replace(t, repetitions=repetitions) if t.repetitions > 1 else t
                  for t in campaign.tests)
    return dataclasses.replace(campaign, tests=tests)


# Tests beyond the dissertation whose every repetition is a long simulation of
# its own keep their campaign's repetitions (fewer when asked): the damped
# beam's 4 records of 8 h, each under a new ambient force (its [check] gates
# are set for 4; 20 took a third of the reproduction's CPU time).
OWN_REPETITIONS = {"ch5-damped": ("random",)}


def reproduction_campaign(name: str, repetitions: int | None) -> Campaign:
    """Campaign ``name`` as the reproduction runs it: the tests an identification
    of :data:`STEPS` reads (ch4-case1 uses its 0.5 rad/s tests alone) with
    ``repetitions`` as :func:`campaign_with_repetitions` gives them, but
    :data:`OWN_REPETITIONS`."""
    from structbench.harness.campaign import load_campaign
    base, steps = load_campaign(CAMPAIGNS / f"{name}.toml"), [s for s in STEPS if s.campaign == name]
    own = {t.name: t.repetitions for t in base.tests if t.name in OWN_REPETITIONS.get(name, ())}
    tests = tuple(dataclasses.replace(t, repetitions=min(own.get(t.name, t.repetitions), t.repetitions))
                  for t in campaign_with_repetitions(CAMPAIGNS / f"{name}.toml", repetitions).tests
                  if any((not s.groups or t.group in s.groups)
                         and (not s.tests or any(fnmatch(t.name, p) for p in s.tests)) for s in steps))
    return dataclasses.replace(base, tests=tests)


DONE = "reproduced.json"  # in OUT/<case>/ once the case is complete: what it ran with
LANES = 2  # cases at the same time; ORDER: longest first by CPU time (each case's last progress line),
# so that the last to start is short
ORDER = ("ch4-case2", "ch5-damped", "ch5-beam", "ch3", "ch4-case1", "ch3-damped", "ch5-membrane")


def _complete(folder: Path, name: str, done: dict[str, Any]) -> bool:
    """Whether ``folder`` holds case ``name`` complete as ``done`` asks (repetitions; traces kept)."""
    try:
        was = json.loads((folder / DONE).read_text())
        ok = was["repetitions"] == done["repetitions"] and (was["traces_kept"] or not done["traces_kept"])
    except (OSError, ValueError, KeyError, TypeError):
        return False
    return ok and all((folder / "results" / f"{s.stem}.json").is_file() for s in STEPS if s.campaign == name)


def run_case(name: str, out: Path, repetitions: int | None, jobs: int | None, keep_traces: bool,
             say: Callable[[str], None]) -> dict[str, Any]:
    """Simulate, identify and score one case into ``out/<name>``; returns its
    scores. Every progress line names the case and its time so far; the last
    gives its CPU seconds too (this process's and its finished children's)."""
    from structbench.dispatch.runs import identify_folder  # imported here, not by the process that
    from structbench.harness.run import run_campaign  # only hands the cases to the lanes
    from .plots import case_figures  # drawn here, beside the other lane's case, not after the last
    from .scores import score_campaign
    start, label, folder = time.perf_counter(), f"[{NAMES.index(name) + 1}/{len(NAMES)}] {name}", out / name
    cpu = sum(os.times()[:4])
    done = {"repetitions": repetitions, "traces_kept": keep_traces}

    def line(text: str) -> None:
        say(f"{label} {time.perf_counter() - start:5.1f} s: {text}")

    if _complete(folder, name, done):
        line("complete from an earlier run: its results scored again")
        return score_campaign(folder)
    (folder / DONE).unlink(missing_ok=True)
    campaign = reproduction_campaign(name, repetitions)
    line(f"simulating {sum(t.repetitions for t in campaign.tests)} traces through the FMU")
    status = run_campaign(campaign, folder, jobs=jobs, fmu_dir=out / "fmus")
    if status.failed:
        raise UserError(f"{status.failed} test(s) failed; see {folder / 'status.json'}", field=name)
    line(f"simulated ({status.skipped} of {len(status.tests)} tests were there already)")
    for step in (s for s in STEPS if s.campaign == name):
        begun = time.perf_counter()
        identify_folder(folder, step.method, groups=step.groups or None, tests=step.tests or None,
                        joint=step.joint, tag=step.tag, options=step.options,
                        jobs=None if jobs is None else max(1, jobs), repetitions=step.repetitions,
                        diagrams=1)  # the report shows each results file's first stabilisation diagram
        line(f"identified {step.stem} ({time.perf_counter() - begun:.1f} s): {step.variant}")
    scores = score_campaign(folder)
    case_figures(out, name)
    if not keep_traces:
        shutil.rmtree(folder / "traces", ignore_errors=True)
    (folder / DONE).write_text(json.dumps(done) + "\n")
    kept = "" if keep_traces else "; traces deleted (--keep-traces keeps them)"
    line(f"done, {sum(os.times()[:4]) - cpu:.1f} CPU s{kept}")
    return scores


def run_all(out: Path, repetitions: int | None, jobs: int | None, say: Callable[[str], None],
            keep_traces: bool = False) -> dict[str, dict[str, Any]]:
    """Every case (:func:`run_case`); returns scores per campaign. ``jobs``
    processes in all (default one per core): two cases at a time, each with
    half of them (under 2: in the case's own process); 0 or 1: one case after
    the other here. ``keep_traces``: keep every case's trace files."""
    missing = [n for n in NAMES if not (CAMPAIGNS / f"{n}.toml").is_file()]
    if missing:
        raise UserError(f"campaign files {missing} not found in {CAMPAIGNS} (a broken installation)",
                        field="campaigns")
    total = (os.cpu_count() or 1) if jobs is None else jobs
    if total <= 1:
        return {name: run_case(name, out, repetitions, jobs, keep_traces, say) for name in NAMES}
    each = total // LANES if total >= 2 * LANES else 0  # 0: in the lane's own process
    scores = _run_lanes([(name, out, repetitions, each, keep_traces) for name in ORDER], say)
    return {name: scores[name] for name in NAMES}


# ---- cases two at a time, each lane a Python of its own (started by subprocess) ----
LANE = ("import sys; sys.path[:] = sys.argv[3:]; from structbench.evaluation.reproduce import serve_lane; "
        "serve_lane(int(sys.argv[1]), int(sys.argv[2]))")


class _Lane:
    """A Python running :func:`serve_lane` (its output on the caller's stderr):
    cases in over one pipe, progress lines and scores back over the other."""

    def __init__(self, queue: deque) -> None:
        (to_child, from_parent), (to_parent, from_child) = os.pipe(), os.pipe()
        from structbench.harness.child import host_path  # standard library only
        self.process = subprocess.Popen([sys.executable, "-c", LANE, str(to_child), str(from_child), *host_path()],
                                        pass_fds=(to_child, from_child), stdin=subprocess.DEVNULL, stdout=2)
        os.close(to_child)
        os.close(from_child)
        self.send, self.recv = Connection(from_parent, readable=False), Connection(to_parent, writable=False)
        self.start(queue)

    def start(self, queue: deque) -> None:
        self.case: str | None = queue[0][0] if queue else None
        if queue:
            self.send.send(queue.popleft())

    def close(self) -> None:
        self.send.close()
        self.recv.close()
        self.process.wait()  # it exits once the pipe is closed (after its case, when one runs)


def _run_lanes(cases: list[tuple[Any, ...]], say: Callable[[str], None]) -> dict[str, dict[str, Any]]:
    """Run ``cases`` (:func:`run_case`'s arguments but ``say``) on :data:`LANES`
    lanes; the first error stops the dispatching and is raised once the
    running cases are done."""
    queue, scores, error = deque(cases), {}, None
    lanes = [_Lane(queue) for _ in range(min(LANES, len(cases)))]
    try:
        from . import plots  # noqa: F401 - matplotlib for the report, imported while the lanes work
        while busy := {lane.recv: lane for lane in lanes if lane.case}:
            for conn in wait(list(busy)):
                lane = busy[conn]
                try:
                    kind, value = conn.recv()
                except EOFError:
                    code = lane.process.wait()
                    kind, value = "error", RuntimeError(f"{lane.case}: its process died (exit status {code})")
                if kind == "line":
                    say(value)
                    continue
                if kind == "scores":
                    scores[lane.case] = value
                error = error or (value if kind == "error" else None)
                lane.start(queue if error is None and lane.process.poll() is None else deque())
    finally:
        for lane in lanes:
            lane.close()
    if error is not None:
        raise error
    return scores


def serve_lane(read_fd: int, write_fd: int) -> None:
    """A lane's loop: run each case received, sending its progress lines and
    then its scores (or its error), until the pipe closes."""
    recv, send = Connection(read_fd, writable=False), Connection(write_fd, readable=False)
    while True:
        try:
            args = recv.recv()
        except EOFError:
            return
        try:
            answer: tuple[str, Any] = ("scores", run_case(*args, say=lambda text: send.send(("line", text))))
        except UserError as err:  # rebuilt from its text: every subclass then unpickles
            answer = ("error", UserError(str(err)))
        except Exception as err:  # noqa: BLE001 - handed to the caller, which raises it
            traceback.print_exc()
            answer = ("error", RuntimeError(f"{args[0]}: {type(err).__name__}: {err}"))
        send.send(answer)


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

