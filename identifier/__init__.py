"""Identification methods that read trace files and a prior model, one
sub-package per method. Imports only :mod:`structbench.models`: never the
harness, the FMU layer or the truth.

- :mod:`.io`: trace files in, result files out
- :mod:`.least_squares`: chapter 3, element mass, damping and stiffness by
  least squares on the equations of motion (the dissertation's ordinary least
  squares and the bias-compensated estimator over every sample)
- :mod:`.perturbation`: chapter 4, frequency-domain perturbation with
  unmeasured responses as pseudo-parameters
- :mod:`.rayleigh`: chapter 5, modes from a pseudo-Rayleigh quotient
- :mod:`.frf`: frequency response functions (H1, H2, Hv) with coherence and
  confidence bands from random, impulse and stepped-sine tests
- :mod:`.modal`: modes with damping and standard errors by covariance-driven
  SSI (:mod:`.modal.ssi`), close pairs from free decays
  (:mod:`.modal.close_pairs`)
"""
from .errors import IdentificationError

__all__ = ["IdentificationError"]
