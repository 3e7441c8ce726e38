"""Identification methods that read trace files and a model description.

Nothing here imports the harness's simulation code or reads truth.json.
"""
