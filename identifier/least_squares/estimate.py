"""The solution of a least-squares identification over the unknown parameters."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass
class Estimate:
    """``values``, ``std_errors`` (same units), ``condition`` (of the
    column-scaled regression matrix), ``residual_rms`` (N),
    ``n_equations``; ``details`` says how it was obtained."""

    values: np.ndarray
    std_errors: np.ndarray
    condition: float
    residual_rms: float
    n_equations: int
    details: dict[str, Any] = field(default_factory=dict)
