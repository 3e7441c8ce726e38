"""Errors for bad user input; the CLI prints them without a traceback (exit 2)."""
from __future__ import annotations


class UserError(ValueError):
    """Bad input from the user. ``field`` names the offending field or variable."""

    def __init__(self, message: str, field: str | None = None):
        self.field = field
        super().__init__(f"{field}: {message}" if field else message)


class ModelError(UserError):
    """A model description is invalid."""
