"""Fixtures shared by several test modules."""
from fmu_fixtures import fmus  # noqa: F401  (session fixture: the built FMUs)

import sys
from pathlib import Path

# benchmarks/modal_synth.py: fast exact modal responses, shared by the modal tests and benchmarks
sys.path.append(str(Path(__file__).resolve().parents[1] / "benchmarks"))
