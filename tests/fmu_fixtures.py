"""Shared fixtures of the FMU tests: the FMUs are built once per session."""
from __future__ import annotations

from pathlib import Path

import pytest

from structbench.models import DISSERTATION, load_model
from structbench.fmus import build_fmu

ROOT = Path(__file__).resolve().parents[1]
SHEAR_FRAME = str(ROOT / "docs" / "examples" / "shear-frame-3.toml")
NAMES = [*DISSERTATION, SHEAR_FRAME]
_BUILT: dict[str, Path] = {}


@pytest.fixture(scope="session")
def fmus(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Structure name (or the TOML path) -> built FMU."""
    if not _BUILT:
        out = tmp_path_factory.mktemp("fmus")
        _BUILT.update({name: build_fmu(load_model(name), out) for name in NAMES})
    return _BUILT
