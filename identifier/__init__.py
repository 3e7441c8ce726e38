"""Identification methods that read trace files and a model description.

Nothing here imports the harness's simulation code or reads truth.json.

- :mod:`identifier.traces`: the trace reader (``read_trace``, ``read_traces``)
- :mod:`identifier.least_squares`: chapter 3, time-domain least squares
- :mod:`identifier.perturbation`: chapter 4, frequency-domain perturbation with pseudo-parameters
- :mod:`identifier.rayleigh`: chapter 5, pseudo-Rayleigh quotient
- :mod:`identifier.modal`: output-only / free-decay modes with damping by SSI-cov
  (:mod:`identifier.ssi_covariance`, :mod:`identifier.ssi_poles`, :mod:`identifier.stabilisation`,
  :mod:`identifier.modal_uncertainty`)
- :mod:`identifier.results`: the result records and their JSON file
- helpers: :mod:`identifier.integrate` (accelerations to motion), :mod:`identifier.harmonic`
  (sinusoid fits, free-vibration frequencies)
"""
from .errors import IdentificationError

__all__ = ["IdentificationError"]
