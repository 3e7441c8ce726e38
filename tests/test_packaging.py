"""One namespace: a plain install puts only ``structbench`` at top level
(the README's examples run in tests/test_examples.py)."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def venv(tmp_path_factory) -> Path:
    """A fresh venv with this checkout's wheel installed (no dependencies: a
    ``.pth`` line lends it the test environment's site-packages for those)."""
    tmp = tmp_path_factory.mktemp("wheel")
    subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(tmp / "dist"), str(ROOT)],
                   check=True, capture_output=True)
    wheel = next((tmp / "dist").glob("structbench-*.whl"))
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(tmp / "venv")], check=True)
    python = tmp / "venv" / "bin" / "python"
    subprocess.run([sys.executable, "-m", "pip", "--python", str(python), "install", "-q", "--no-deps", str(wheel)],
                   check=True, capture_output=True)
    (site_packages(tmp / "venv") / "_test_dependencies.pth").write_text(
        "\n".join(p for p in sys.path if p.endswith("site-packages")) + "\n")
    return tmp / "venv"


def site_packages(venv: Path) -> Path:
    return next((venv / "lib").glob("python3*/site-packages"))


def _python(venv: Path, code: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    return subprocess.run([str(venv / "bin" / "python"), "-c", code], cwd=cwd, env=env, capture_output=True,
                          text=True)


def test_only_structbench_is_installed_at_top_level(venv):
    site = site_packages(venv)
    names = {p.name for p in site.iterdir()} - {"_test_dependencies.pth", "__pycache__"}
    assert {n for n in names if not n.endswith(".dist-info")} == {"structbench"}
    packages = sorted(str(p.parent.relative_to(site)) for p in site.rglob("__init__.py"))
    assert packages == ["structbench", "structbench/campaigns", "structbench/cli", "structbench/dispatch",
                        "structbench/evaluation", "structbench/fmus", "structbench/harness", "structbench/identifier",
                        "structbench/identifier/frf", "structbench/identifier/io", "structbench/identifier/least_squares",
                        "structbench/identifier/modal", "structbench/identifier/modal/close_pairs",
                        "structbench/identifier/modal/ssi", "structbench/identifier/perturbation",
                        "structbench/identifier/rayleigh", "structbench/identifier/updating", "structbench/labdata",
                        "structbench/models", "structbench/planning"]
    assert sorted(p.name for p in (site / "structbench" / "campaigns").glob("*.toml")) == sorted(
        p.name for p in (ROOT / "campaigns").glob("*.toml"))


def test_import_structbench_works_and_import_models_fails(venv, tmp_path):
    ok = _python(venv, "import structbench, structbench.fmus, structbench.cli; print(structbench.__file__); "
                       "from structbench.evaluation.reproduce import CAMPAIGNS; print(CAMPAIGNS)", tmp_path)
    assert ok.returncode == 0, ok.stderr
    package, campaigns = ok.stdout.split()
    assert Path(package).is_relative_to(site_packages(venv))
    assert Path(campaigns) == site_packages(venv) / "structbench" / "campaigns"  # reproduce needs no checkout
    for name in ("models", "bench", "identifier", "benchmarks", "fmus"):
        missing = _python(venv, f"import {name}", tmp_path)
        assert missing.returncode == 1 and "ModuleNotFoundError" in missing.stderr, name
    script = subprocess.run([str(venv / "bin" / "structbench"), "modes", "ch5-membrane", "--count", "2", "--json"],
                            cwd=tmp_path, capture_output=True, text=True)
    assert script.returncode == 0, script.stderr
    assert '"omega"' in script.stdout
