"""Checks of JSON documents read back from disk (results files, truth.json):
each failure names the file and the key path, as a :class:`UserError`."""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from structbench.models.errors import UserError


class JsonError(UserError):
    """A JSON file is unreadable or a value in it has the wrong type."""


def load_json(path: Path) -> Any:
    """The parsed file; unreadable or invalid JSON is a :class:`JsonError`."""
    try:
        return json.loads(path.read_bytes())
    except (OSError, ValueError, RecursionError) as err:
        raise JsonError(f"not readable JSON: {err}", field=str(path)) from None


class Doc:
    """A value inside a JSON file at ``where`` (``runs[2].parameters[0]``)."""

    def __init__(self, path: Path, value: Any, where: str = ""):
        self.path, self.value, self.where = path, value, where

    def error(self, message: str) -> JsonError:
        return JsonError(f"{self.where or 'top level'}: {message}", field=self.path.name)

    def _child(self, key: str | int, value: Any) -> "Doc":
        where = f"{self.where}[{key}]" if isinstance(key, int) else f"{self.where}.{key}".lstrip(".")
        return Doc(self.path, value, where)

    def obj(self) -> dict[str, Any]:
        if not isinstance(self.value, dict):
            raise self.error(f"expected an object, got {type(self.value).__name__}")
        return self.value

    def key(self, name: str, default: Any = ...) -> "Doc":
        """The member ``name`` (required unless ``default`` is given)."""
        data = self.obj()
        if name not in data:
            if default is ...:
                raise self.error(f"missing key {name!r}")
            return self._child(name, default)
        return self._child(name, data[name])

    def items(self) -> list["Doc"]:
        if not isinstance(self.value, list):
            raise self.error(f"expected a list, got {type(self.value).__name__}")
        return [self._child(i, v) for i, v in enumerate(self.value)]

    def string(self) -> str:
        if not isinstance(self.value, str):
            raise self.error(f"expected a string, got {self.value!r:.60}")
        return self.value

    def number(self, finite: bool = False, optional: bool = False) -> float | None:
        """A real number (NaN/inf allowed unless ``finite``), or None when ``optional``."""
        if self.value is None and optional:
            return None
        if isinstance(self.value, bool) or not isinstance(self.value, (int, float)):
            raise self.error(f"expected a number, got {self.value!r:.60}")
        if finite and not math.isfinite(self.value):
            raise self.error(f"expected a finite number, got {self.value}")
        return float(self.value)

    def integer(self, optional: bool = False) -> int | None:
        if self.value is None and optional:
            return None
        if isinstance(self.value, bool) or not isinstance(self.value, int):
            raise self.error(f"expected an integer, got {self.value!r:.60}")
        return self.value

    def numbers(self, length: int | None = None, finite: bool = False) -> list[float]:
        values = [d.number(finite) for d in self.items()]
        if length is not None and len(values) != length:
            raise self.error(f"expected {length} numbers, got {len(values)}")
        return values

    def strings(self) -> list[str]:
        return [d.string() for d in self.items()]

    def allow(self, keys: set[str]) -> None:
        unknown = sorted(set(self.obj()) - keys)
        if unknown:
            raise self.error(f"unknown key(s) {unknown}; known: {sorted(keys)}")
