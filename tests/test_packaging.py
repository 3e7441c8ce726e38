"""One namespace: a plain install puts only ``structbench`` at top level, and
the README's notebook example runs end to end through the Python API."""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> Path:
    """The wheel of this checkout installed (without dependencies) into a folder of its own."""
    tmp = tmp_path_factory.mktemp("wheel")
    subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(tmp / "dist"), str(ROOT)],
                   check=True, capture_output=True)
    wheel = next((tmp / "dist").glob("structbench-*.whl"))
    subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--target", str(tmp / "site"),
                    str(wheel)], check=True, capture_output=True)
    return tmp / "site"


def _python(code: str, site: Path, cwd: Path) -> subprocess.CompletedProcess:
    env = os.environ | {"PYTHONPATH": str(site)}
    return subprocess.run([sys.executable, "-c", code], cwd=cwd, env=env, capture_output=True, text=True)


def test_only_structbench_is_installed_at_top_level(installed):
    names = {p.name for p in installed.iterdir()} - {"bin"}
    assert {n for n in names if not n.endswith(".dist-info")} == {"structbench"}
    packages = sorted(str(p.parent.relative_to(installed)) for p in installed.rglob("__init__.py"))
    assert packages == ["structbench", "structbench/cli", "structbench/evaluation", "structbench/fmus",
                        "structbench/harness", "structbench/identification", "structbench/identifier",
                        "structbench/labdata", "structbench/models"]
    assert sorted(p.name for p in (installed / "structbench" / "campaigns").glob("*.toml")) == sorted(
        p.name for p in (ROOT / "campaigns").glob("*.toml"))


def test_import_structbench_works_and_import_models_fails(installed, tmp_path):
    ok = _python("import structbench, structbench.fmus, structbench.cli; print(structbench.__file__)", installed,
                 tmp_path)
    assert ok.returncode == 0, ok.stderr
    assert Path(ok.stdout.strip()).is_relative_to(installed)
    for name in ("models", "bench", "identifier", "benchmarks", "fmus"):
        missing = _python(f"import {name}", installed, tmp_path)
        assert missing.returncode == 1 and "ModuleNotFoundError" in missing.stderr, name


def test_readme_notebook_example_runs(tmp_path):
    readme = (ROOT / "README.md").read_text()
    section = readme[readme.index("## From Python"):]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    (tmp_path / "campaigns").symlink_to(ROOT / "campaigns")
    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0] == "2 tests done, 0 failed"
    assert "'label': 'mass[1]'" in lines[1] and "'unit': 'kg/m'" in lines[1]
    rms = float(lines[2].split(":")[1])
    assert 0.005 < rms < 0.027  # chapter 3, m = 8: the campaign's own gate (dissertation 0.0183)
    assert lines[3:] and all(line.startswith("least-squares-m8 ") and line.endswith("PASS") for line in lines[3:])
