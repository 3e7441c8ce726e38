"""Errors for bad user input; the CLI prints them without a traceback (exit 2)."""
from __future__ import annotations


class UserError(ValueError):
    """Bad input from the user. ``field`` names the offending field or variable;
    ``where`` the file and line it is in, when known (see :meth:`at`)."""

    def __init__(self, message: str, field: str | None = None):
        self.field = field
        self.where: str | None = None
        super().__init__(f"{field}: {message}" if field else message)

    def at(self, where: str) -> UserError:
        """This error located in a file: ``where`` (``model.toml:12``) leads
        its message; ``field`` stays the key path. Returns the error."""
        self.where = where
        self.args = (f"{where}: {self.args[0]}", *self.args[1:])
        return self


class ModelError(UserError):
    """A model description is invalid."""
