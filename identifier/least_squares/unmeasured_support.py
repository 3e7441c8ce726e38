"""Least squares with unmeasured DOF: whether the lines can support an
estimate at all (:func:`check_support`), see
:mod:`identifier.least_squares.unmeasured`."""
from __future__ import annotations

from ..errors import IdentificationError


def check_support(info: dict, n_determined: int, unmeasured: list) -> None:
    """Refuse an estimate its lines cannot support: ``n_c`` clusters of
    correlated lines (``info["clusters"]``) no more than the ``n_d``
    determined parameters. The sandwich covariance ``A^-1 (sum_c g_c
    g_c^T) A^-1`` then has rank ``n_c <= n_d`` and its small-sample factor
    ``n_c / (n_c - n_d)`` is undefined, so no error estimate independent of
    the variances ``V`` exists; and so few lines (a displacement-only test:
    rigid-body drift leaves a few dozen coherent lines at the lowest
    frequencies) leave the output error far from linear over the
    parameters' spread, where the model-based ``A^-1`` fails too. Raises
    :class:`IdentificationError` naming the counts and the unmeasured DOF."""
    n_c = info.get("clusters", 0)
    if n_c > n_determined:
        return
    raise IdentificationError(
        f"the data cannot support an estimate: {info['lines']} coherent lines in {n_c} clusters of correlated "
        f"lines for {n_determined} determined parameters (more clusters than parameters needed for a standard "
        f"error that holds); unmeasured DOF {', '.join(f'({n}, {d!r})' for n, d in unmeasured[:6])}"
        f"{' ...' if len(unmeasured) > 6 else ''}: measure velocities or accelerations (a displacement test of "
        "a free structure leaves few coherent lines), a longer record, or more DOF", field="channels")

