"""Fixtures shared by several test modules."""
from fmu_fixtures import fmus  # noqa: F401  (session fixture: the built FMUs)
