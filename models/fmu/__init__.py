"""Structures as FMI 2.0 co-simulation FMUs (pythonfmu).

``runtime`` (numpy/scipy only) and ``slave`` (the pythonfmu slave) are bundled
into each FMU; ``builder`` packages a :class:`models.Structure` or
:class:`models.ModalModel`: ``build_fmu(model, out_dir) -> Path``.
"""
from __future__ import annotations

from typing import Any


def __getattr__(name: str) -> Any:
    # lazy: models.statespace imports .runtime while models is still initialising
    if name == "build_fmu":
        from .builder import build_fmu
        return build_fmu
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
