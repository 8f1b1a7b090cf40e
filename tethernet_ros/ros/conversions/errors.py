"""The error a request or setup field raises when it is invalid."""
from __future__ import annotations


class RequestError(ValueError):
    """A request or setup field is invalid; the message names the field (one line)."""

    def __init__(self, field: str, message: str):
        super().__init__(f"{field}: {message}")
        self.field = field
