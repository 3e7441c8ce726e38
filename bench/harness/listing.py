"""What a campaign output folder holds: status, truth, and per test its
trace files, sampling and channels (read from the trace attributes). A
folder made by ``structbench import`` (no campaign run, no status) is
described by its traces: campaign and structure names and the lab files
they came from."""
from __future__ import annotations

import json
from pathlib import Path

import h5py

from structbench.models.errors import UserError


def trace_summary(path: Path) -> dict:
    """A trace file's test, repetition, sampling and channels (from its attributes)."""
    with h5py.File(path, "r") as f:
        time = f["time"]
        excitation = f.get("excitation")
        return {"file": path.name, "test": str(f.attrs["test"]), "repetition": int(f.attrs["repetition"]),
                "dt": float(f.attrs["dt"]), "samples": int(time.shape[0]),
                "duration": float(time[-1] - time[0]) if time.shape[0] else 0.0,
                "channels": list(f["channels"]),
                "excitation": str(excitation.attrs.get("kind", "")) if excitation is not None else "",
                "omega": float(excitation.attrs["omega"]) if excitation is not None and "omega" in excitation.attrs
                else None} | ({"source": str(f.attrs["source"])} if "source" in f.attrs else {})


def _names(path: Path) -> dict[str, str]:
    """A trace file's campaign and structure names (root attributes)."""
    with h5py.File(path, "r") as f:
        return {key: str(f.attrs.get(key, "")) for key in ("campaign", "structure")}


def listing(folder: Path) -> dict:
    """The folder's status, truth presence and a summary per test."""
    traces = sorted((folder / "traces").glob("*.h5"))
    if not folder.is_dir() or not ((folder / "campaign.toml").exists() or traces):
        raise UserError("not a campaign output folder (no campaign.toml, no traces/*.h5)", field=str(folder))
    status_file = folder / "status.json"
    status = json.loads(status_file.read_text()) if status_file.exists() else {}
    tests: dict[str, dict] = {}
    sources: set[str] = set()  # the lab files of an imported folder
    for path in traces:
        info = trace_summary(path)
        if "source" in info:
            sources.add(info["source"])
        entry = tests.setdefault(info["test"], {**info, "files": 0})
        entry["files"] += 1
    for name, st in status.get("tests", {}).items():
        tests.setdefault(name, {"test": name, "files": 0})
        tests[name] |= {"state": st["state"], "expected": len(st["traces"]), "error": st["error"]}
    imported = not status and not (folder / "campaign.toml").exists() and bool(sources)
    names = _names(traces[0]) if traces and not status else {}  # no status.json: the traces say
    return {"folder": str(folder), "campaign": status.get("campaign", names.get("campaign", "")),
            "structure": status.get("structure", names.get("structure", "")),
            "fmu_sha256": status.get("fmu_sha256", ""), "truth": (folder / "truth.json").exists(),
            "bytes": sum(p.stat().st_size for p in traces), "summary": status.get("summary", {}),
            "imported": imported, "sources": sorted(sources), "tests": list(tests.values())}
