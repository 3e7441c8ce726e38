"""An FMU runs in a fresh virtualenv that has fmpy, numpy and scipy but neither
structbench nor pythonfmu.

The venv is made without pip (offline and fast); the installed distributions
of numpy, scipy and fmpy, with their dependencies, are linked into its
site-packages, so exactly those packages are importable there.
"""
from __future__ import annotations

import json
import re
import subprocess
import sys
import textwrap
from importlib import metadata
from pathlib import Path

import numpy as np
import pytest

from structbench.models import load_model

SCRIPT = textwrap.dedent("""
    import importlib.util, json, sys
    for name in ("models", "bench", "identifier", "structbench", "pythonfmu"):
        assert importlib.util.find_spec(name) is None, name + " is importable"
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    path, n, dt = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
    md = read_model_description(path)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(path),
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="venv")
    fmu.instantiate(loggingOn=True)
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    out = []
    for k in range(n):
        fmu.setReal([vr["F_7_w"]], [1.0])
        out.append(fmu.getReal([vr["u_7_w"], vr["a_2_w"]]))
        fmu.doStep(k * dt, dt)
    fmu.terminate()
    fmu.freeInstance()
    print(json.dumps(out))
""")


def _closure(names: list[str]) -> list[metadata.Distribution]:
    """The installed distributions ``names`` and everything they require (no extras)."""
    seen: dict[str, metadata.Distribution] = {}
    todo = list(names)
    while todo:
        name = re.sub(r"[-_.]+", "-", todo.pop()).lower()
        if name in seen:
            continue
        try:
            dist = seen[name] = metadata.distribution(name)
        except metadata.PackageNotFoundError:
            continue  # an optional or platform-specific requirement
        todo += [re.match(r"[A-Za-z0-9._-]+", req).group() for req in dist.requires or ()
                 if "extra ==" not in req]
    return list(seen.values())


def _venv(root: Path) -> Path:
    """A pip-less venv with numpy, scipy and fmpy linked in; its python."""
    made = subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(root)],
                          capture_output=True, text=True)
    python = root / "bin" / "python"
    if made.returncode != 0 or not python.exists():
        pytest.skip(f"cannot create a virtualenv here: {made.stderr.strip()}")
    site = Path(subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                               capture_output=True, text=True, check=True).stdout.strip())
    for dist in _closure(["numpy", "scipy", "fmpy"]):
        tops = {Path(f).parts[0] for f in dist.files or ()} - {"..", "__pycache__"}
        for top in tops:
            source = Path(dist.locate_file(top))
            if source.exists() and not (site / top).exists():
                (site / top).symlink_to(source)
    return python


def test_fmu_runs_in_a_venv_without_structbench(fmus, tmp_path):
    python = _venv(tmp_path / "venv")
    script = tmp_path / "run_fmu.py"
    script.write_text(SCRIPT)
    n, dt = 200, 0.01
    done = subprocess.run([str(python), "-I", str(script), str(fmus["ch4-cantilever-case1"]), str(n), str(dt)],
                          capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert done.returncode == 0, done.stderr
    got = np.array(json.loads(done.stdout.splitlines()[-1]))
    model = load_model("ch4-cantilever-case1")
    force = np.zeros((n, model.n_dof))
    force[:, model.dof_index(7, "w")] = 1.0
    ref = model.state_space().simulate(force, dt)
    np.testing.assert_allclose(got[:, 0], ref["displacement"][:, model.dof_index(7, "w")], rtol=1e-10, atol=0)
    np.testing.assert_allclose(got[:, 1], ref["acceleration"][:, model.dof_index(2, "w")], rtol=1e-9,
                               atol=1e-12)
