"""A child Python (workers, reproduce lanes) started while an FMU is open in
this process: pythonfmu has put the FMU's ``resources/`` (with a copy of
pythonfmu that lacks its binaries) on ``sys.path``; the child must import
the installed pythonfmu, or the FMUs it builds cannot be loaded."""
from __future__ import annotations

import subprocess
import sys
import zipfile

import pytest

from structbench.fmus import build_fmu
from structbench.harness.child import host_path
from structbench.harness.fmu_session import FmuSession
from structbench.models import load_model
from structbench.models.errors import ModelError

PROBE = ("import sys; sys.path[:] = sys.argv[1:]; import pathlib, pythonfmu; "
         "print(len(list(pathlib.Path(pythonfmu.__file__).parent.glob('resources/binaries/*/*'))))")


def binaries_seen_by_child(path: list[str]) -> int:
    return int(subprocess.run([sys.executable, "-c", PROBE, *path], capture_output=True, text=True,
                              check=True).stdout)


def test_children_import_the_installed_pythonfmu_while_an_fmu_is_open(fmus, tmp_path):
    with FmuSession(fmus["ch4-cantilever-case1"]):
        resources = [p for p in sys.path if p not in host_path()]
        assert resources and all(p.endswith("resources") for p in resources)  # what pythonfmu did (this FMU's
        # and those of FMUs other tests of this session keep open)
        assert binaries_seen_by_child(sys.path) == 0  # the whole sys.path: the FMU's copy of pythonfmu
        assert binaries_seen_by_child(host_path()) >= 1
        script = ("import sys; sys.path[:] = sys.argv[2:]; from structbench.fmus import build_fmu; "
                  "from structbench.models import load_model; build_fmu(load_model('ch4-cantilever-case2'), sys.argv[1])")
        subprocess.run([sys.executable, "-c", script, str(tmp_path), *host_path()], check=True)
    names = zipfile.ZipFile(tmp_path / "ch4-cantilever-case2.fmu").namelist()
    assert any(n.startswith("binaries/linux64/") and n.endswith(".so") for n in names)


def test_a_pythonfmu_without_binaries_is_refused(monkeypatch, tmp_path):
    monkeypatch.setattr("structbench.fmus.builder._binaries", lambda: [])
    with pytest.raises(ModelError, match="no export binaries"):
        build_fmu(load_model("ch4-cantilever-case2"), tmp_path)
    assert not list(tmp_path.iterdir())  # nothing written
