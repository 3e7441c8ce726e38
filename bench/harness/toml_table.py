"""Reading a TOML table with the key path and line of every value, so that
each validation error names ``file:line: key`` (campaign files)."""
from __future__ import annotations

import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Protocol

from structbench.models.errors import UserError

from .external import closest
from .toml_lines import Path as KeyPath
from .toml_lines import line_of

REQUIRED = object()

class CampaignError(UserError):
    """A campaign file is invalid; ``field`` reads ``file:line: key``."""



class Reader(Protocol):
    """What a :class:`Table` needs of its file: an error at a key path."""

    def error(self, key: KeyPath, message: str) -> CampaignError: ...


def key_error(path: Path, lines: Mapping[KeyPath, int], key: KeyPath, message: str) -> CampaignError:
    shown = "".join(f"[{k + 1}]" if isinstance(k, int) else f".{json.dumps(k) if '.' in k else k}"
                    for k in key).lstrip(".")
    line = line_of(lines, key)
    return CampaignError(message, field=f"{path.name}:{line}: {shown}" if line else f"{path.name}: {shown}")



class Table:
    """A TOML table with the key path each entry came from (for errors)."""

    def __init__(self, reader: "Reader", data: dict[str, Any], origin: dict[str, KeyPath], where: KeyPath):
        self.reader, self.data, self.origin, self.where = reader, data, origin, where

    def at(self, key: str) -> KeyPath:
        return self.origin.get(key, self.where + (key,))

    def error(self, key: str, message: str) -> CampaignError:
        return self.reader.error(self.at(key), message)

    def allow(self, allowed: tuple[str, ...], what: str) -> None:
        for key in self.data:
            if key not in allowed:
                near = closest(key, allowed, 1)
                hint = f" (did you mean {near[0]!r}?)" if near else ""
                raise self.error(key, f"unknown key in {what}{hint}; allowed: {', '.join(allowed)}")

    def get(self, key: str, default: Any = REQUIRED) -> Any:
        if key not in self.data:
            if default is REQUIRED:
                raise self.reader.error(self.where + (key,), "missing (required)")
            return default
        return self.data[key]

    def number(self, key: str, default: Any = REQUIRED, low: float | None = None,
               positive: bool = False) -> float:
        value = self.get(key, default)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise self.error(key, f"expected a finite number, got {value!r}")
        if positive and value <= 0:
            raise self.error(key, f"must be positive, got {value}")
        if low is not None and value < low:
            raise self.error(key, f"must be at least {low}, got {value}")
        return float(value)

    def integer(self, key: str, default: Any = REQUIRED, low: int | None = None) -> int:
        value = self.get(key, default)
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.error(key, f"expected an integer, got {value!r}")
        if low is not None and value < low:
            raise self.error(key, f"must be at least {low}, got {value}")
        return value

    def string(self, key: str, default: Any = REQUIRED, choices: tuple[str, ...] | None = None) -> str:
        value = self.get(key, default)
        if not isinstance(value, str):
            raise self.error(key, f"expected a string, got {value!r}")
        if choices is not None and value not in choices:
            raise self.error(key, f"{value!r} is not one of {', '.join(choices)}")
        return value

    def table(self, key: str) -> "Table":
        value = self.get(key, {})
        if not isinstance(value, dict):
            raise self.error(key, f"expected a table, got {value!r}")
        return Table(self.reader, value, {}, self.at(key))

    def tables(self, key: str) -> list["Table"]:
        value = self.get(key, [])
        if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
            raise self.error(key, "expected an array of tables")
        return [Table(self.reader, v, {}, self.at(key) + (i,)) for i, v in enumerate(value)]


