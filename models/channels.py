"""Measurement channels, the vocabulary of trace files shared by every layer:
a quantity at a (node, direction), its name ``<quantity>_<node>_<direction>``
and SI unit, and the trace format's name (``docs/trace-format.md``)."""
from __future__ import annotations

from dataclasses import dataclass

TRACE_FORMAT = "structbench-trace"
TRACE_FORMAT_VERSION = 1
QUANTITIES = ("displacement", "velocity", "acceleration", "force")
ROTATIONS = frozenset({"theta", "rx", "ry", "rz"})

_UNITS = {"displacement": ("m", "rad"), "velocity": ("m/s", "rad/s"),
          "acceleration": ("m/s^2", "rad/s^2"), "force": ("N", "N m")}


def unit(quantity: str, direction: str) -> str:
    """SI unit of ``quantity`` on a translation or (``theta``, ``r*``) rotation."""
    return _UNITS[quantity][direction in ROTATIONS]


@dataclass(frozen=True, order=True)
class Channel:
    """One sensor channel; ``name`` is ``<quantity>_<node>_<direction>``."""

    quantity: str
    node: int
    direction: str

    @property
    def name(self) -> str:
        return f"{self.quantity}_{self.node}_{self.direction}"

    @property
    def unit(self) -> str:
        return unit(self.quantity, self.direction)

    @property
    def dof(self) -> tuple[int, str]:
        return (self.node, self.direction)
