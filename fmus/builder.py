"""Package a structure as an FMI 2.0 co-simulation FMU (pythonfmu).

Layout of ``<name>.fmu`` (``<mod>`` = ``sb_<structure>_<hash>``, unique per
content, so FMUs never shadow each other or the host's packages):

    modelDescription.xml
    binaries/<platform>/<mod>.so|.dll   pythonfmu's export library
    resources/slavemodule.txt           "<mod>"
    resources/<mod>.py                  the slave (fmus/slave.py)
    resources/<mod>_rt.py               the runtime (models/dynamics.py)
    resources/<mod>.json                variables and model data (fmus/spec.py)
    resources/pythonfmu/*.py            pythonfmu itself, for hosts without it

Building is deterministic and skipped when the FMU at the target path was
built from the same content.
"""
from __future__ import annotations

import contextlib
import hashlib
import importlib
import json
import os
import re
import sys
import tempfile
import uuid
import zipfile
from pathlib import Path
from typing import Iterator
from xml.dom.minidom import parseString
from xml.etree.ElementTree import tostring

import pythonfmu

from structbench.models import dynamics
from structbench.models.errors import ModelError
from structbench.models.modal import ModalModel
from structbench.models.structure import Structure
from .spec import fmu_spec

HERE = Path(__file__).parent
PYTHONFMU = Path(pythonfmu.__file__).parent
ZIP_DATE = (1980, 1, 1, 0, 0, 0)


def fmu_filename(name: str) -> str:
    """File name of a structure's FMU: the structure name made file-safe."""
    return (re.sub(r"[^A-Za-z0-9._-]+", "-", name).strip("-.") or "model") + ".fmu"


def _binaries() -> list[tuple[Path, str]]:
    """pythonfmu's export libraries as ``(file, binaries/ subfolder)``."""
    root = PYTHONFMU / "resources" / "binaries"
    return sorted((f, f.parent.name) for f in root.glob("*/*") if f.suffix in {".so", ".dll", ".dylib"})


def _module_name(model_name: str, content: bytes) -> str:
    slug = re.sub(r"[^a-z0-9]+", "_", model_name.lower()).strip("_")[:40] or "model"
    return f"sb_{slug}_{hashlib.sha256(content).hexdigest()[:12]}"


def built_module(path: Path) -> str | None:
    """The slave module an existing FMU was built with (None if unreadable)."""
    try:
        with zipfile.ZipFile(path) as zf:
            return zf.read("resources/slavemodule.txt").decode().strip()
    except (OSError, KeyError, zipfile.BadZipFile):
        return None


@contextlib.contextmanager
def _imported(folder: Path, module: str) -> Iterator[object]:
    """Import ``module`` from ``folder``, then forget it (sys.path, sys.modules)."""
    sys.path.insert(0, str(folder))
    try:
        yield importlib.import_module(module)
    finally:
        sys.path.remove(str(folder))
        for name in (module, module + "_rt"):
            sys.modules.pop(name, None)


def _model_description(stage: Path, module: str) -> bytes:
    """Instantiate the staged slave once to check the model and write its XML."""
    with _imported(stage, module) as mod:
        slave = mod.StructureSlave(instance_name="build", resources=str(stage))
        slave.get_real([0])  # assembles the model with the default parameters
        if slave.problems:
            raise ModelError("; ".join(slave.problems.values()), field="model")
        xml = slave.to_xml()
    return parseString(tostring(xml, "UTF-8")).toprettyxml(encoding="UTF-8")


def build_fmu(model: Structure | ModalModel, out_dir: str | Path) -> Path:
    """Build ``out_dir/<name>.fmu`` for ``model`` and return its path; a no-op
    when that file was already built from the same model and code."""
    out_dir = Path(out_dir)
    spec = fmu_spec(model)
    sources = {"slave": (HERE / "slave.py").read_bytes(), "runtime": Path(dynamics.__file__).read_bytes()}
    content = b"\0".join([json.dumps(spec, sort_keys=True).encode(), sources["slave"], sources["runtime"],
                          pythonfmu.__version__.encode()])
    module = _module_name(model.name, content)
    target = out_dir / fmu_filename(model.name)
    if target.exists() and built_module(target) == module:
        return target
    spec["guid"] = str(uuid.UUID(hashlib.sha256(content).hexdigest()[:32]))
    files: dict[str, bytes] = {
        f"resources/{module}.py": sources["slave"],
        f"resources/{module}_rt.py": sources["runtime"],
        f"resources/{module}.json": json.dumps(spec, indent=1).encode(),
        "resources/slavemodule.txt": module.encode(),
    }
    files.update({f"resources/pythonfmu/{f.name}": f.read_bytes() for f in sorted(PYTHONFMU.glob("*.py"))})
    binaries = _binaries()
    if not binaries:
        raise ModelError(f"pythonfmu at {PYTHONFMU} has no export binaries (resources/binaries/*/): an FMU built "
                         "with it could not be loaded; is an FMU's resources folder on sys.path?", field="pythonfmu")
    files.update({f"binaries/{platform}/{module}{f.suffix}": f.read_bytes() for f, platform in binaries})
    with tempfile.TemporaryDirectory(prefix="sb_fmu_") as tmp:
        stage = Path(tmp)
        for name in (f"{module}.py", f"{module}_rt.py", f"{module}.json"):
            (stage / name).write_bytes(files[f"resources/{name}"])
        files["modelDescription.xml"] = _model_description(stage, module)
    out_dir.mkdir(parents=True, exist_ok=True)
    handle, name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".part", dir=out_dir)
    partial = Path(name)  # this process's own: processes building the same FMU at once never share one
    try:
        with os.fdopen(handle, "wb") as raw, zipfile.ZipFile(raw, "w", zipfile.ZIP_DEFLATED) as zf:
            for name in sorted(files):
                info = zipfile.ZipInfo(name, ZIP_DATE)
                info.external_attr = 0o644 << 16  # rw-r--r--
                zf.writestr(info, files[name], zipfile.ZIP_DEFLATED)
        partial.chmod(0o644)
        partial.replace(target)  # atomic: a reader sees the old file or the whole new one
    finally:
        partial.unlink(missing_ok=True)
    return target


def default_fmu_dir() -> Path:
    """Where built FMUs go unless told otherwise: ``$STRUCTBENCH_FMU_DIR``, else
    ``$XDG_CACHE_HOME/structbench/fmus`` (``~/.cache/structbench/fmus``); never
    next to the source."""
    if os.environ.get("STRUCTBENCH_FMU_DIR"):
        return Path(os.environ["STRUCTBENCH_FMU_DIR"])
    cache = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(cache) / "structbench" / "fmus"
