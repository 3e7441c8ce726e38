"""structbench: a virtual vibration-test lab (structures as FMUs, an
fmpy-driven harness, identification methods, scoring against the truth).

This package is the public face: the Python API of :mod:`structbench.api`,
which may import every subpackage; nothing else imports the API but the CLI.
Subpackages: ``models`` (structures), ``fmus`` (the FMU layer), ``harness``
(campaigns to traces), ``identifier`` (methods reading traces),
``dispatch`` (methods run on a campaign folder), ``labdata`` (lab
files in and out), ``evaluation``
(scoring, gates, report, reproduce), ``cli`` (the command line over the API).

The public names are loaded on first use (``structbench.run_campaign``
imports the API then), so that importing a subpackage, or the command
line's ``--help``, does not pay for numpy, scipy, h5py and matplotlib.
"""
from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

__all__ = ["BuiltFmu", "Campaign", "CampaignStatus", "Method", "UserError", "build_fmus", "check",
           "export_modes", "export_traces", "frf", "identify", "import_data", "list_traces", "load_campaign", "methods",
           "model_geometry", "modes", "plan", "plot_modes", "reproduce", "reproduce_table", "results_file",
           "run_campaign", "score", "write_junit"]

if TYPE_CHECKING:  # what static checkers see; at run time __getattr__ loads these
    from .api import (BuiltFmu, Campaign, CampaignStatus, Method, UserError, build_fmus, check, export_modes,
                      export_traces, frf, identify, import_data, list_traces, load_campaign, methods, model_geometry,
                      modes, plan, plot_modes, reproduce, reproduce_table, results_file, run_campaign, score, write_junit)


def __getattr__(name: str) -> Any:
    """A public name of :mod:`structbench.api`, imported on first use."""
    if name in __all__:
        value = getattr(importlib.import_module(".api", __name__), name)
        globals()[name] = value  # later look-ups skip this function
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
