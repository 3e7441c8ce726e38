"""Dispatch: what a campaign folder holds (listing), the method registry and the identifiers run on a campaign
folder. Imports the identifier and models, never the harness or fmus."""
