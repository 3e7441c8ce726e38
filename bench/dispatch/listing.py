"""What a campaign output folder holds: status, truth, and per test its
trace files, sampling and channels (read from the trace attributes). A
folder made by ``structbench import`` (no campaign run, no status) is
described by its traces: campaign and structure names and the lab files
they came from."""
from __future__ import annotations

import json
from pathlib import Path

from structbench.identifier.io.traces import read_contents, read_info
from structbench.models.errors import UserError


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
        info = read_contents(path)
        if "source" in info:
            sources.add(info["source"])
        entry = tests.setdefault(info["test"], {**info, "files": 0})
        entry["files"] += 1
    for name, st in status.get("tests", {}).items():
        tests.setdefault(name, {"test": name, "files": 0})
        tests[name] |= {"state": st["state"], "expected": len(st["traces"]), "error": st["error"]}
    imported = not status and not (folder / "campaign.toml").exists() and bool(sources)
    names = read_info(traces[0]).attrs if traces and not status else {}  # no status.json: the traces say
    return {"folder": str(folder), "campaign": status.get("campaign", str(names.get("campaign", ""))),
            "structure": status.get("structure", str(names.get("structure", ""))),
            "fmu_sha256": status.get("fmu_sha256", ""), "truth": (folder / "truth.json").exists(),
            "bytes": sum(p.stat().st_size for p in traces), "summary": status.get("summary", {}),
            "imported": imported, "sources": sorted(sources), "tests": list(tests.values())}
