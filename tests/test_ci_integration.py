"""CI integration (issue 24.3): the pytest plugin (entry point ``pytest11``)
runs a campaign once into a content-addressed cache and asserts its
``[check]`` gates; a second CI run with the cache restored simulates
nothing; a pytest run of an unrelated project is left as it was; docs/ci.md's
workflow runs as written."""
from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest

from structbench.pytest_plugin import assert_gates, cache_dir, cache_key, cached_campaign, working_folder

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("numpy", "scipy", "h5py", "fmpy", "matplotlib", "dask", "structbench.api", "structbench.harness")

CAMPAIGN = f'''
name = "frame-ci"
structure = "{ROOT / "docs" / "examples" / "shear-frame-3.toml"}"
seed = 1

[check.modal]
freq_error_pct_max = 0.5
mac_min = 0.99

[check.modal-strict]
coverage_max = 0.5

[[tests]]
name = "impulse"
dt = 0.002
duration = 20.0

[[tests.excitation]]
kind = "impulse"
node = 1
dir = "x"
impulse = 100.0
method = "initial-velocity"

[[tests.sensors]]
nodes = "all"
quantities = ["acceleration"]
'''

# The user's side of a CI run: a counter of the FMU steps simulated (every
# simulation passes through FmuSession.run; jobs = 0 keeps them in the test
# process) and a test of the gates.
COUNTING_CONFTEST = '''
import os
from structbench.harness import fmu_session

_run = fmu_session.FmuSession.run


def _counting(self, inputs, outputs, forces, *args, **kwargs):
    with open(os.environ["FMU_STEPS"], "a") as log:
        log.write(f"{len(forces)}\\n")
    return _run(self, inputs, outputs, forces, *args, **kwargs)


fmu_session.FmuSession.run = _counting
'''

GATES_TEST = '''
from structbench.pytest_plugin import assert_gates


def test_modal_gates(structbench_campaign):
    rows = assert_gates(structbench_campaign("frame.toml"), "modal", jobs=1)
    assert sorted(r["gate"] for r in rows) == ["freq_error_pct_max", "mac_min"]


def test_one_folder_per_session(structbench_campaign, structbench_cache):
    folder = structbench_campaign("frame.toml")
    assert structbench_campaign("./frame.toml") == folder
    assert (folder / "traces").resolve().parent.parent == structbench_cache
'''


def run_pytest(project: Path, *args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    environment = {k: v for k, v in os.environ.items() if not k.startswith(("PYTEST_", "STRUCTBENCH_"))}
    return subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *args], cwd=project,
                          capture_output=True, text=True, timeout=600, env=environment | (env or {}))


def snapshot(cache: Path) -> dict[str, tuple[int, int, str]]:
    """Every file of the cache: (inode, mtime in ns, sha256)."""
    return {str(p.relative_to(cache)): (p.stat().st_ino, p.stat().st_mtime_ns,
                                        hashlib.sha256(p.read_bytes()).hexdigest())
            for p in sorted(cache.rglob("*")) if p.is_file() and not p.name.endswith(".lock")}


def test_importing_the_plugin_loads_nothing_heavy():
    code = ("import sys, structbench.pytest_plugin\n"
            f"print([m for m in {HEAVY!r} if m in sys.modules])")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0 and done.stdout.strip() == "[]", done.stderr


def test_an_unrelated_project_is_left_alone(tmp_path):
    """The plugin is loaded (its entry point) but imports, creates and changes nothing."""
    (tmp_path / "test_other.py").write_text(
        "import sys\n\n\ndef test_other():\n"
        "    assert 'structbench.pytest_plugin' in sys.modules\n"
        f"    assert [m for m in {HEAVY!r} if m in sys.modules] == []\n")
    done = run_pytest(tmp_path, env={"STRUCTBENCH_CACHE": str(tmp_path / "cache")})
    assert done.returncode == 0, done.stdout + done.stderr
    assert re.search(r"^1 passed", done.stdout, re.M)
    assert [p.name for p in tmp_path.iterdir() if p.name != "__pycache__"] == ["test_other.py"]


def test_a_second_ci_run_with_the_cache_restored_simulates_nothing(tmp_path):
    project = tmp_path / "project"
    project.mkdir()
    (project / "frame.toml").write_text(CAMPAIGN)
    (project / "pytest.ini").write_text("[pytest]\nstructbench_jobs = 0\n")
    (project / "conftest.py").write_text(COUNTING_CONFTEST)
    (project / "test_frame_gates.py").write_text(GATES_TEST)
    first, second = tmp_path / "steps-1", tmp_path / "steps-2"

    cache = tmp_path / "cache"
    done = run_pytest(project, "--structbench-cache", str(cache), env={"FMU_STEPS": str(first)})
    assert done.returncode == 0, done.stdout + done.stderr
    assert first.read_text().split() == ["10001"]  # the counter sees the simulation: 0 to 20 s at 2 ms
    (entry,) = [p for p in cache.iterdir() if p.is_dir() and p.name != "fmus"]
    assert len(list((entry / "traces").glob("*.h5"))) == 1 and not (entry / "results").exists()

    restored = tmp_path / "restored"  # CI restores the cache folder into a new machine's workspace
    shutil.copytree(cache, restored)
    before = snapshot(restored)
    done = run_pytest(project, env={"FMU_STEPS": str(second), "STRUCTBENCH_CACHE": str(restored)})
    assert done.returncode == 0, done.stdout + done.stderr
    assert not second.exists()  # no FMU step: nothing simulated
    assert snapshot(restored) == before  # no trace, status or FMU rewritten, no results written into the cache


def test_the_key_is_campaign_text_fmu_and_version():
    key = cache_key("name = 'a'\n", "0" * 64, "0.2.0")
    assert re.fullmatch(r"[0-9a-f]{64}", key) and key == cache_key("name = 'a'\n", "0" * 64, "0.2.0")
    assert len({key, cache_key("name = 'b'\n", "0" * 64, "0.2.0"), cache_key("name = 'a'\n", "1" * 64, "0.2.0"),
                cache_key("name = 'a'\n", "0" * 64, "0.2.1"), cache_key("name = 'a'\n0", "" * 64, "0.2.0")}) == 5


def test_where_the_cache_is(tmp_path, monkeypatch):
    def config(option: str | None, ini: str) -> SimpleNamespace:
        return SimpleNamespace(getoption=lambda name, default=None: option, getini=lambda name: ini,
                               rootpath=tmp_path)

    monkeypatch.setenv("STRUCTBENCH_CACHE", str(tmp_path / "env"))
    assert cache_dir(config(str(tmp_path / "cli"), "ini")) == tmp_path / "cli"
    assert cache_dir(config(None, "ini")) == tmp_path / "ini"
    assert cache_dir(config(None, "")) == tmp_path / "env"
    monkeypatch.delenv("STRUCTBENCH_CACHE")
    assert cache_dir(config(None, "")) == Path.home() / ".cache" / "structbench" / "campaigns"


@pytest.fixture(scope="module")
def cached(tmp_path_factory) -> tuple[Path, Path]:
    """(the campaign file, its cache folder) after one run."""
    base = tmp_path_factory.mktemp("cached")
    (base / "frame.toml").write_text(CAMPAIGN)
    cached_campaign(base / "frame.toml", base / "cache", jobs=0)
    return base / "frame.toml", base / "cache"


def test_a_failing_gate_lists_value_threshold_and_campaign(cached, tmp_path):
    campaign, cache = cached
    folder = working_folder(cached_campaign(campaign, cache, jobs=0), tmp_path / "work", campaign)
    with pytest.raises(pytest.fail.Exception) as failed:
        assert_gates(folder, "modal", tag="strict", jobs=1)
    message = str(failed.value)
    assert message.startswith(f"1 of 1 [check] gates failed for modal-strict (method modal) on {campaign}:")
    assert "FAIL  modal-strict coverage_max = 1 > 0.5 (threshold) in campaign frame-ci" in message
    assert (folder / "results" / "modal-strict.json").is_file()
    assert not (cache / json.loads((folder / "pytest-source.json").read_text())["cache"] / "results").exists()


def test_a_damaged_entry_is_simulated_again(cached, tmp_path, monkeypatch):
    campaign, cache = cached
    copy = tmp_path / "cache"
    shutil.copytree(cache, copy)
    entry = cached_campaign(campaign, copy, jobs=0)
    (trace,) = (entry / "traces").glob("*.h5")
    good = trace.read_bytes()
    trace.write_bytes(good[:1000])
    from structbench.harness import fmu_session
    made = []
    run = fmu_session.FmuSession.run
    monkeypatch.setattr(fmu_session.FmuSession, "run", lambda self, i, o, f, *a, **k: made.append(len(f)) or run(self, i, o, f, *a, **k))
    assert cached_campaign(campaign, copy, jobs=0) == entry
    assert made == [10001] and trace.read_bytes() == good
    made.clear()
    cached_campaign(campaign, copy, jobs=0)
    assert made == []


def titled_blocks(document: Path) -> dict[str, str]:
    """The fenced blocks of a Markdown file that name their file (```sh title=ci.sh)."""
    return {m[1]: m[2] for m in re.finditer(r"^```\w+ title=(\S+)\n(.*?)^```$", document.read_text(), re.M | re.S)}


def test_the_ci_doc_runs_as_written(tmp_path):
    """docs/ci.md: the plugin project with its campaign, test and CI script;
    two CI runs, each in a fresh copy of the project and a fresh Python
    site for the plugin, the cache folder carried from the first to the
    second. FMU steps are counted through a conftest.py beside the test,
    with the campaign run in the test process (PYTEST_ADDOPTS)."""
    blocks = titled_blocks(ROOT / "docs" / "ci.md")
    assert sorted(blocks) == ["ci.sh", "frame.toml", "test_frame_gates.py"]
    project = tmp_path / "project"
    shutil.copytree(ROOT / "docs" / "examples" / "structbench-peaks", project,
                    ignore=shutil.ignore_patterns("build", "*.egg-info", "__pycache__"))
    shutil.copy(ROOT / "docs" / "examples" / "shear-frame-3.toml", project)
    for name, text in blocks.items():
        (project / name).write_text(text)
    (project / "conftest.py").write_text(COUNTING_CONFTEST)

    def ci_run(n: int) -> tuple[subprocess.CompletedProcess, Path, Path]:
        checkout, site, steps = tmp_path / f"run-{n}", tmp_path / f"site-{n}", tmp_path / f"steps-{n}"
        shutil.copytree(project, checkout, ignore=shutil.ignore_patterns(".structbench-cache"))
        if n > 1:  # the CI's cache step restores the folder
            shutil.copytree(tmp_path / f"run-{n - 1}" / ".structbench-cache", checkout / ".structbench-cache")
        environment = {k: v for k, v in os.environ.items() if not k.startswith(("PYTEST_", "STRUCTBENCH_", "PIP_"))}
        environment |= {"PIP_TARGET": str(site), "PIP_NO_DEPS": "1", "PIP_NO_BUILD_ISOLATION": "0",
                        "PYTHONPATH": str(site), "PYTEST_ADDOPTS": "--structbench-jobs 0", "FMU_STEPS": str(steps),
                        "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}"}
        done = subprocess.run(["sh", "ci.sh"], cwd=checkout, env=environment, capture_output=True, text=True,
                              timeout=600)
        assert done.returncode == 0, done.stdout + done.stderr
        assert re.search(r"^2 passed", done.stdout, re.M), done.stdout
        report = (checkout / "reports" / "gates.xml").read_text()
        assert report.count("<testcase ") == 2 and 'failures="0"' in report
        return done, checkout / ".structbench-cache", steps

    _, cache, steps = ci_run(1)
    assert steps.read_text().split() == ["15001"]  # 0 to 30 s at 2 ms
    assert (site := tmp_path / "site-1").is_dir() and list(site.glob("structbench_peaks*"))
    before = snapshot(cache)
    _, restored, steps = ci_run(2)
    assert not steps.exists()  # no FMU step: nothing simulated
    assert {k: v[1:] for k, v in snapshot(restored).items()} == {k: v[1:] for k, v in before.items()}
