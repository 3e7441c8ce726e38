"""Units of lab files to SI: a label (``g``, ``mm/s``, ``in``, ``lbf`` ...)
gives the physical dimension, the structbench quantity and the factor to SI.

``si = factor * value``; the factors are exact by definition (inch 0.0254 m,
standard gravity 9.80665 m/s^2, pound-force 4.4482216152605 N).
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass

from structbench.models.errors import UserError

G = 9.80665            # m/s^2 per g
INCH = 0.0254          # m
FOOT = 0.3048          # m
LBF = 4.4482216152605  # N
DEG = math.pi / 180.0  # rad

# dimension -> (structbench quantity or "time", rotation?, SI unit)
DIMENSIONS = {
    "length": ("displacement", False, "m"), "velocity": ("velocity", False, "m/s"),
    "acceleration": ("acceleration", False, "m/s^2"), "force": ("force", False, "N"),
    "angle": ("displacement", True, "rad"), "angular velocity": ("velocity", True, "rad/s"),
    "angular acceleration": ("acceleration", True, "rad/s^2"), "moment": ("force", True, "N m"),
    "time": ("time", False, "s"),
}

_LENGTH = {"m": 1.0, "mm": 1e-3, "cm": 1e-2, "um": 1e-6, "in": INCH, "ft": FOOT}
_ANGLE = {"rad": 1.0, "mrad": 1e-3, "deg": DEG}
_FORCE = {"N": 1.0, "kN": 1e3, "mN": 1e-3, "lbf": LBF, "kgf": G}


def _table() -> dict[str, tuple[str, float]]:
    table: dict[str, tuple[str, float]] = {}
    for name, f in _LENGTH.items():
        table |= {name: ("length", f), f"{name}/s": ("velocity", f), f"{name}/s^2": ("acceleration", f)}
    for name, f in _ANGLE.items():
        table |= {name: ("angle", f), f"{name}/s": ("angular velocity", f),
                  f"{name}/s^2": ("angular acceleration", f)}
    for name, f in _FORCE.items():
        table[name] = ("force", f)
        for length, g in _LENGTH.items():
            for joint in (" ", "*", ".", "-", ""):
                table.setdefault(f"{name}{joint}{length}", ("moment", f * g))
    table |= {"g": ("acceleration", G), "G": ("acceleration", G),
              "s": ("time", 1.0), "ms": ("time", 1e-3), "us": ("time", 1e-6)}
    return table


UNITS = _table()


def normalize(label: str) -> str:
    """A unit label in the table's spelling: ``m/s²``, ``m/s**2``, ``m/sec^2``
    and ``m/s2`` all become ``m/s^2``; ``µ`` becomes ``u``."""
    text = label.strip().replace("²", "^2").replace("**", "^").replace("µ", "u").replace("μ", "u")
    text = re.sub(r"sec\b", "s", text)
    return re.sub(r"/s2$", "/s^2", text)


@dataclass(frozen=True)
class Conversion:
    """A file's unit ``label`` and how it becomes SI: ``si = factor * value``."""

    label: str
    dimension: str
    factor: float

    @property
    def quantity(self) -> str:
        return DIMENSIONS[self.dimension][0]

    @property
    def rotation(self) -> bool:
        return DIMENSIONS[self.dimension][1]

    @property
    def si_unit(self) -> str:
        return DIMENSIONS[self.dimension][2]


def conversion(label: str, channel: str) -> Conversion:
    """The conversion of unit ``label``; an unknown unit is a :class:`UserError`
    naming ``channel``."""
    found = UNITS.get(normalize(label))
    if found is None:
        raise UserError(f"unknown unit {label!r}; known: g, m, mm, in, ft, m/s, mm/s, in/s, m/s^2, N, kN, lbf, "
                        "rad, deg, N m, s, ms and their combinations", field=channel)
    return Conversion(label.strip(), *found)


def time_factor(label: str, where: str) -> float:
    """Seconds per unit of a time axis labelled ``label`` (``s``, ``ms``, ``us``)."""
    found = conversion(label, where)
    if found.dimension != "time":
        raise UserError(f"the time axis has unit {label!r}, a {found.dimension}: no time axis", field=where)
    return found.factor
