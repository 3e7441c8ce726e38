"""The harness: campaign files to trace files (campaign, excitation, noise, FMU
session, workers and Dask, truth). Imports models and fmus, never the identifiers."""
