"""structbench: a virtual vibration-test lab (structures as FMUs, an
fmpy-driven harness, identification methods, scoring against the truth).

This package is the public face: the Python API of :mod:`structbench.api`,
which may import every subpackage; nothing else imports the API but the CLI.
Subpackages: ``models`` (structures), ``fmus`` (the FMU layer), ``harness``
(campaigns to traces), ``identifier`` (methods reading traces),
``dispatch`` (methods run on a campaign folder), ``labdata`` (lab
files in and out), ``evaluation``
(scoring, gates, report, reproduce), ``cli`` (the command line over the API).
"""
from .api import (BuiltFmu, Campaign, CampaignStatus, Method, UserError, build_fmus, check, export_traces,
                  identify, import_data, list_traces, load_campaign, methods, modes, reproduce, reproduce_table, results_file,
                  run_campaign, score)

__all__ = ["BuiltFmu", "Campaign", "CampaignStatus", "Method", "UserError", "build_fmus", "check",
           "export_traces", "identify", "import_data", "list_traces", "load_campaign", "methods", "modes", "reproduce", "reproduce_table",
           "results_file", "run_campaign", "score"]
