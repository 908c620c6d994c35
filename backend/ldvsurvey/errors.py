"""Typed errors a user can cause. Each names the file, the line and the field.

The API maps :class:`InputError` to a 4xx answer and the CLI to exit code 2.
"""

from __future__ import annotations


class InputError(Exception):
    """Invalid input a user can fix: a bad file, parameter or request.

    Parameters
    ----------
    message : str
        What is wrong, in words a user can act on.
    file : str, optional
        Name of the file concerned (as in the bundle, e.g. ``imu.csv``).
    line : int, optional
        1-based line number in that file.
    field : str, optional
        Column, key or parameter name.
    """

    status_code = 422

    def __init__(self, message: str, *, file: str | None = None, line: int | None = None, field: str | None = None):
        self.message = message
        self.file = file
        self.line = line
        self.field = field
        super().__init__(str(self))

    def __str__(self) -> str:
        where = []
        if self.file:
            where.append(self.file)
        if self.line is not None:
            where.append(f"line {self.line}")
        if self.field:
            where.append(f"field '{self.field}'")
        prefix = ", ".join(where)
        return f"{prefix}: {self.message}" if prefix else self.message

    def to_dict(self) -> dict:
        """JSON-ready description (used by the API error body)."""
        return {"message": self.message, "file": self.file, "line": self.line, "field": self.field, "detail": str(self)}


class BundleError(InputError):
    """A drive-log bundle that does not follow ``ldv-drive-log/1``."""


class ParameterError(InputError):
    """A pipeline parameter that is unknown, malformed or out of range."""


class TooLargeError(InputError):
    """An upload or archive that exceeds a configured size limit (HTTP 413)."""

    status_code = 413
