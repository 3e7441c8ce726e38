"""Fixtures shared by several test modules."""
from fmu_fixtures import fmus  # noqa: F401  (session fixture: the built FMUs)

import sys
from pathlib import Path

# benchmarks/modal_synth.py: fast exact modal responses, shared by the modal tests and benchmarks
sys.path.append(str(Path(__file__).resolve().parents[1] / "benchmarks"))

from hypothesis import HealthCheck, settings  # noqa: E402

# fuzz tests (tests/test_fuzz_*.py): the same cases on every run, few enough for CI;
# benchmarks/fuzz_long.py runs the same properties with 1,000+ cases per format
settings.register_profile("ci", derandomize=True, max_examples=40, deadline=None, database=None,
                          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                                 HealthCheck.function_scoped_fixture])
settings.load_profile("ci")
