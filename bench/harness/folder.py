"""A campaign's output folder: ``campaign.toml`` (copy), ``traces/*.h5``,
``truth.json`` and ``status.json``.

Trace files are written atomically and ``status.json`` records the sha256 of
each once it is booked; a campaign started again in the same folder skips the
traces whose checksum matches, checks the contents of those without a recorded
checksum (:mod:`.trace_check`), and deletes (to simulate again) the others.
"""
from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from structbench.models.errors import UserError

from .campaign import Campaign
from .fmu_setup import Bench
from .trace_check import is_trace_of
from .trace_writer import write_atomic

STATUS_FORMAT = "structbench-status"


def _now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


def file_sha256(path: Path) -> str:
    """sha256 of a file, hex."""
    return hashlib.sha256(path.read_bytes()).hexdigest()


def write_json(path: Path, data: Any) -> None:
    write_atomic(path, (json.dumps(data, indent=1) + "\n").encode())


@dataclass
class TestStatus:
    """Progress of one test: its trace files, those present, an error if it failed."""

    name: str
    group: str
    traces: list[str]
    present: set[str] = field(default_factory=set)
    error: str | None = None
    omega: float | None = None
    sha256: dict[str, str] = field(default_factory=dict)  # trace file -> checksum

    @property
    def state(self) -> str:
        """``done``, ``failed`` or ``pending``."""
        if self.error is not None:
            return "failed"
        return "done" if self.present.issuperset(self.traces) else "pending"

    def to_json(self) -> dict[str, Any]:
        return {"state": self.state, "group": self.group, "omega": self.omega, "traces": self.traces,
                "present": sorted(self.present), "error": self.error,
                "sha256": dict(sorted(self.sha256.items()))}


@dataclass
class CampaignStatus:
    """Progress of a campaign run (``status.json``)."""

    campaign: str
    structure: str
    fmu: str
    fmu_sha256: str
    tests: dict[str, TestStatus]
    started: str = field(default_factory=_now)
    skipped: int = 0  # tests complete before this run
    warnings: list[dict[str, Any]] = field(default_factory=list)  # step check (step_check.py): test, channel, message

    def count(self, state: str) -> int:
        return sum(t.state == state for t in self.tests.values())

    @property
    def failed(self) -> int:
        return self.count("failed")

    def to_json(self) -> dict[str, Any]:
        return {"format": STATUS_FORMAT, "campaign": self.campaign, "structure": self.structure,
                "fmu": self.fmu, "fmu_sha256": self.fmu_sha256, "started": self.started, "updated": _now(),
                "summary": {s: self.count(s) for s in ("done", "failed", "pending")} | {"skipped": self.skipped},
                "warnings": self.warnings,
                "tests": {name: t.to_json() for name, t in self.tests.items()}}


class Folder:
    """The output folder of one campaign."""

    def __init__(self, root: str | Path):
        self.root = Path(root)
        self.traces = self.root / "traces"

    def prepare(self, campaign: Campaign) -> None:
        """Create the folder, copy the campaign (refusing another campaign's
        folder) and remove temporary files left by a killed run."""
        copy = self.root / "campaign.toml"
        if copy.exists() and copy.read_text() != campaign.text:
            raise UserError(f"{self.root} holds the results of a different campaign.toml; "
                            "use another --out folder", field="--out")
        self.traces.mkdir(parents=True, exist_ok=True)
        if not copy.exists():
            write_atomic(copy, campaign.text.encode())
        self.remove_partial()

    def remove_partial(self) -> None:
        """Remove the temporary files of trace writes that never finished (a
        killed run, or a worker killed mid-write with a crashing or hung FMU)."""
        for tmp in self.traces.glob(".*.tmp"):
            tmp.unlink(missing_ok=True)

    def recorded(self) -> dict[str, str]:
        """Trace file -> sha256 as booked in ``status.json`` (none if unreadable)."""
        try:
            tests = json.loads((self.root / "status.json").read_text())["tests"]
            return {name: digest for t in tests.values() for name, digest in t.get("sha256", {}).items()
                    if isinstance(name, str) and isinstance(digest, str)}
        except (OSError, ValueError, KeyError, TypeError, AttributeError):
            return {}

    def keep_verified(self, campaign: Campaign, bench: Bench) -> dict[str, str]:
        """The trace files present that can be kept, with their checksums: those
        whose checksum matches ``status.json``, and those it does not record
        that hold the right trace (:func:`.trace_check.is_trace_of`: an older
        folder, or a file written after the last status update). The others
        (damaged files, strays) are deleted, to be simulated again."""
        recorded, good = self.recorded(), {}
        expected = {t.trace_name(r): (t, r) for t in campaign.tests for r in range(t.repetitions)}
        for path in self.traces.glob("*.h5"):
            digest = file_sha256(path)
            if recorded.get(path.name) == digest or (
                    path.name not in recorded and path.name in expected
                    and is_trace_of(path, bench, *expected[path.name])):
                good[path.name] = digest
            else:
                path.unlink()
        return good

    def status(self, campaign: Campaign, bench: Bench) -> CampaignStatus:
        """A fresh status with what is already present (checksums verified)."""
        present = self.keep_verified(campaign, bench)
        tests = {}
        for t in campaign.tests:
            names = [t.trace_name(r) for r in range(t.repetitions)]
            omega = next((i.omega for i in t.excitation if i.kind == "harmonic"), None)
            have = {n: present[n] for n in names if n in present}
            tests[t.name] = TestStatus(t.name, t.group, names, set(have), omega=omega, sha256=have)
        status = CampaignStatus(campaign.name, campaign.structure, bench.fmu, bench.fmu_sha256, tests)
        status.skipped = status.count("done")
        return status

    def write_status(self, status: CampaignStatus) -> None:
        write_json(self.root / "status.json", status.to_json())

    def write_truth(self, truth: dict[str, Any] | None) -> None:
        if truth is not None:
            write_json(self.root / "truth.json", truth)

    def write_trace(self, name: str, image: bytes) -> None:
        write_atomic(self.traces / name, image)
