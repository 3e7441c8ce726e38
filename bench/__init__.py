"""The fmpy-driven virtual test lab: campaigns, excitation, noise, traces, scoring, CLI."""
