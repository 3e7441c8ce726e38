"""Evaluation: scores of results against truth.json, [check] gates, the report
and its plots, and the dissertation's reproduction. Imports the harness, the
identification runner, the identifier's result format, models, and planning
(the Cramer-Rao bound beside least-squares scores, efficiency.py)."""
