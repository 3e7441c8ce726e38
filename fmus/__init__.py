"""Structures as FMI 2.0 co-simulation FMUs (pythonfmu): the variable spec,
the slave bundled into each FMU, and the builder. Imports only structbench.models.

``slave.py`` and the runtime (``structbench/models/dynamics.py``, numpy/scipy
only) are copied into each FMU, which then runs without structbench;
:func:`build_fmu` packages a :class:`~structbench.models.Structure` or
:class:`~structbench.models.ModalModel`: ``build_fmu(model, out_dir) -> Path``.
"""
from __future__ import annotations

from .builder import build_fmu, built_module, default_fmu_dir, fmu_filename

__all__ = ["build_fmu", "built_module", "default_fmu_dir", "fmu_filename"]
