"""Variable mapping between (quantity, node, direction) and FMU variable names.

Built-in FMUs follow :data:`BUILTIN_PATTERNS`; an external FMU gets a name
pattern per quantity with ``{node}`` and ``{dir}`` placeholders (e.g.
``Structure.Node{node}.F{dir}``) and/or an explicit table from channel names
(``force_3_z``) to variable names.
"""
from __future__ import annotations

import difflib
import string
from collections.abc import Collection, Mapping
from dataclasses import dataclass, field
from pathlib import Path

QUANTITY_KEYS = ("force", "displacement", "velocity", "acceleration",
                 "initial_displacement", "initial_velocity")
PLACEHOLDERS = frozenset({"node", "dir"})

BUILTIN_PATTERNS = {"force": "F_{node}_{dir}", "displacement": "u_{node}_{dir}",
                    "velocity": "v_{node}_{dir}", "acceleration": "a_{node}_{dir}",
                    "initial_displacement": "u0_{node}_{dir}", "initial_velocity": "v0_{node}_{dir}"}


def pattern_fields(pattern: str) -> set[str]:
    """Placeholder names used in a pattern (raises ValueError on bad braces)."""
    return {f for _, f, _, _ in string.Formatter().parse(pattern) if f is not None}


@dataclass(frozen=True)
class VariableMap:
    """``patterns``: quantity key -> name pattern; ``table``: channel name
    (``<quantity>_<node>_<dir>``) -> variable name, taking precedence."""

    patterns: Mapping[str, str] = field(default_factory=dict)
    table: Mapping[str, str] = field(default_factory=dict)

    def variable(self, quantity: str, node: int, direction: str) -> str | None:
        """The FMU variable of a quantity at a DOF, or None if unmapped."""
        explicit = self.table.get(f"{quantity}_{node}_{direction}")
        if explicit is not None:
            return explicit
        pattern = self.patterns.get(quantity)
        return None if pattern is None else pattern.format(node=node, dir=direction)


BUILTIN = VariableMap(BUILTIN_PATTERNS)


def fmu_variables(path: str | Path) -> dict[str, str]:
    """Variable name -> causality of an FMU (FMI 2 or 3), from its model description."""
    from fmpy import read_model_description

    return {v.name: v.causality for v in read_model_description(str(path)).modelVariables}


def closest(name: str, variables: Collection[str], count: int = 5) -> list[str]:
    """The FMU variables that look most like ``name`` (difflib ratio)."""
    return difflib.get_close_matches(name, list(variables), n=count, cutoff=0.3)
