"""Errors of the identifiers: bad or insufficient input, reported without numbers."""
from __future__ import annotations

from structbench.models.errors import UserError


class IdentificationError(UserError):
    """The traces and the model cannot give an identification (a missing
    channel, DOF that do not match, too few equations, parameters that are
    not identifiable). ``field`` names the offending item."""
