"""Evaluation: scores of results against truth.json, [check] gates, the report
and its plots, and the dissertation's reproduction. Imports the harness, the
identification runner, the identifier's result format and models."""
