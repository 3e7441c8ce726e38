"""Helpers for the end-to-end tests: short variants of the campaign files,
run through the FMUs and the harness, identified and scored by the CLI."""
from __future__ import annotations

import json
import tomllib
from pathlib import Path
from typing import Any

from structbench.cli import main
from structbench import run_campaign
from structbench.evaluation.scores import score_campaign

CAMPAIGNS = Path(__file__).resolve().parents[1] / "campaigns"


def toml_value(value: Any) -> str:
    """One value as inline TOML (strings, numbers, booleans, lists, tables)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{json.dumps(k)} = {toml_value(v)}" for k, v in value.items()) + "}"
    raise TypeError(f"no TOML for {type(value).__name__}")


def toml_text(campaign: dict[str, Any]) -> str:
    """A campaign dict as TOML: top-level keys inline, one ``[[tests]]`` per test."""
    lines = [f"{json.dumps(k)} = {toml_value(v)}" for k, v in campaign.items() if k != "tests"]
    for test in campaign.get("tests", []):
        lines += ["", "[[tests]]"] + [f"{json.dumps(k)} = {toml_value(v)}" for k, v in test.items()]
    return "\n".join(lines) + "\n"


def derive(source: str, folder: Path, tests: dict[str, dict[str, Any]], **top: Any) -> Path:
    """``campaigns/<source>.toml`` cut down to the named ``tests``, each with its
    keys updated (a value of None removes the key; ``excitation`` items are
    updated key by key when given as a dict); ``top`` updates top-level keys.
    Written as ``folder/<source>.toml``."""
    campaign = tomllib.loads((CAMPAIGNS / f"{source}.toml").read_text())
    by_name = {t["name"]: t for t in campaign["tests"]}
    kept = []
    for name, changes in tests.items():
        test = dict(by_name[name])
        for key, value in changes.items():
            if key == "excitation" and isinstance(value, dict):
                test[key] = [item | value for item in test[key]]
            elif value is None:
                test.pop(key, None)
            else:
                test[key] = value
        kept.append(test)
    campaign = campaign | top | {"tests": kept}
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{source}.toml"
    path.write_text(toml_text(campaign))
    return path


def run(campaign: Path, out: Path, fmu_dir: Path | None = None, jobs: int = 0) -> Path:
    """Run a campaign into ``out`` (built-in structures' FMUs from ``fmu_dir``,
    built there if missing); every test must be done."""
    status = run_campaign(campaign, out, jobs=jobs, fmu_dir=fmu_dir)
    assert not status.failed, json.loads((out / "status.json").read_text())["tests"]
    return out


def identify(folder: Path, method: str, *options: str) -> dict[str, Any]:
    """``structbench identify`` (must exit 0; a tag given as ``--tag=T``),
    scored: the scores of its results file."""
    tag = [o.split("=", 1)[1] for o in options if o.startswith("--tag=")]
    assert main(["identify", str(folder), "--method", method, *options]) == 0
    stem = method + (f"-{tag[0]}" if tag else "")
    return score_campaign(folder)[stem]
