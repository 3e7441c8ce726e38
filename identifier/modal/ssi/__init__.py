"""Covariance-driven stochastic subspace identification, the modal method's
core: the record's layout (:mod:`.design`), output covariances and the
principal row channels (:mod:`.covariance`), the block Hankel matrix and its
leading singular subspace (:mod:`.hankel`), poles and shapes at every model
order (:mod:`.poles`). Imports only numpy, scipy and :mod:`..runtime`."""
