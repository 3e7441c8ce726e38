"""What a campaign output folder holds: status, truth, and per test its
trace files, sampling and channels (read from the trace attributes)."""
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
                else None}


def listing(folder: Path) -> dict:
    """The folder's status, truth presence and a summary per test."""
    traces = sorted((folder / "traces").glob("*.h5"))
    if not folder.is_dir() or not ((folder / "campaign.toml").exists() or traces):
        raise UserError("not a campaign output folder (no campaign.toml, no traces/*.h5)", field=str(folder))
    status_file = folder / "status.json"
    status = json.loads(status_file.read_text()) if status_file.exists() else {}
    tests: dict[str, dict] = {}
    for path in traces:
        info = trace_summary(path)
        entry = tests.setdefault(info["test"], {**info, "files": 0})
        entry["files"] += 1
    for name, st in status.get("tests", {}).items():
        tests.setdefault(name, {"test": name, "files": 0})
        tests[name] |= {"state": st["state"], "expected": len(st["traces"]), "error": st["error"]}
    return {"folder": str(folder), "campaign": status.get("campaign", ""), "structure": status.get("structure", ""),
            "fmu_sha256": status.get("fmu_sha256", ""), "truth": (folder / "truth.json").exists(),
            "bytes": sum(p.stat().st_size for p in traces), "summary": status.get("summary", {}),
            "tests": list(tests.values())}
