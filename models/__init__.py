"""Finite-element and modal models of structures (SI units throughout) and
their exact dynamics. Imports nothing else of structbench."""
from __future__ import annotations

from pathlib import Path

from .errors import ModelError
from .library import DISSERTATION, STRUCTURES, Model
from .modal import ModalModel
from .structure import Structure
from .toml_model import load_structure

__all__ = ["DISSERTATION", "STRUCTURES", "ModalModel", "Model", "ModelError", "Structure",
           "load_model"]


def load_model(name_or_path: str | Path) -> Model:
    """A named structure (see :data:`STRUCTURES`) or a TOML model file."""
    key = str(name_or_path)
    if key in STRUCTURES:
        return STRUCTURES[key]()
    if key.endswith(".toml") or Path(key).exists():
        return load_structure(key)
    raise ModelError(f"unknown structure {key!r}: neither a built-in name ({', '.join(STRUCTURES)}) "
                     "nor a TOML file", field="structure")
