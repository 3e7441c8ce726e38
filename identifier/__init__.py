"""Identification methods that read trace files and a model description.
Imports only structbench.models: never the harness, the FMU layer or truth.json.

- :mod:`structbench.identifier.traces`: the trace reader (``read_trace``, ``read_traces``)
- :mod:`structbench.identifier.least_squares`: chapter 3, time-domain least squares
- :mod:`structbench.identifier.perturbation`: chapter 4, frequency-domain perturbation with pseudo-parameters
- :mod:`structbench.identifier.rayleigh`: chapter 5, pseudo-Rayleigh quotient
- :mod:`structbench.identifier.modal`: output-only / free-decay modes with damping by SSI-cov
  (:mod:`structbench.identifier.ssi_design`, :mod:`structbench.identifier.ssi_covariance`,
  :mod:`structbench.identifier.ssi_hankel`, :mod:`structbench.identifier.ssi_poles`,
  :mod:`structbench.identifier.stabilisation`, :mod:`structbench.identifier.modal_uncertainty`); close pairs from two or more free decays by
  :mod:`structbench.identifier.mode_split` (:mod:`structbench.identifier.close_pair`,
  :mod:`structbench.identifier.rank_one_fit`, :mod:`structbench.identifier.free_decay_fit`,
  :mod:`structbench.identifier.local_space`)
- :mod:`structbench.identifier.results`: the result records and their JSON file
- helpers: :mod:`structbench.identifier.integrate` (accelerations to motion), :mod:`structbench.identifier.harmonic`
  (sinusoid fits, free-vibration frequencies)
"""
from .errors import IdentificationError

__all__ = ["IdentificationError"]
