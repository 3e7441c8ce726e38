"""``structbench traces``: what a campaign output folder holds."""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import h5py

from models.errors import UserError

HELP = "list the tests, trace files and channels of a campaign output folder"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("folder", type=Path, metavar="DIR", help="campaign output folder (structbench run --out)")
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")


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


def _table(data: dict) -> str:
    lines = [f"campaign {data['campaign'] or '?'} on {data['structure'] or '?'} "
             f"(FMU sha256 {data['fmu_sha256'][:12] or '?'}); truth.json {'present' if data['truth'] else 'absent'}",
             f"{sum(t['files'] for t in data['tests'])} trace files, {data['bytes'] / 1e6:.1f} MB; "
             + ", ".join(f"{k} {v}" for k, v in data["summary"].items())]
    head = f"{'test':24s} {'state':8s} {'files':>9s} {'dt (s)':>9s} {'samples':>8s} {'channels':>8s}  excitation"
    lines.append(head)
    for t in data["tests"]:
        files = f"{t['files']}/{t.get('expected', t['files'])}"
        omega = f" omega = {t['omega']:g} rad/s" if t.get("omega") is not None else ""
        sampling = (f"{t['dt']:9.4g} {t['samples']:8d} {len(t['channels']):8d}  {t['excitation']}{omega}"
                    if "dt" in t else "")
        lines.append(f"{t['test']:24s} {t.get('state', '?'):8s} {files:>9s} {sampling}")
        if t.get("error"):
            lines.append(f"    error: {t['error']}")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    data = listing(args.folder)
    print(json.dumps(data, indent=1) if args.json else _table(data))
    return 0
