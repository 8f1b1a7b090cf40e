"""The error a request or setup field raises when it is invalid."""
from __future__ import annotations


class RequestError(ValueError):
    """A request or setup field is invalid; the message names the field (one line)."""

    def __init__(self, field: str, message: str):
        super().__init__(f"{field}: {message}")
        self.field = field


def detail(exc: BaseException) -> str:
    """What a core error says after the field it names ("<group> field 'x': got ...;
    must be ..." -> "got ...; must be ..."), for a RequestError naming the request's field."""
    text = str(exc)
    return text.split(": ", 1)[1] if ": " in text else text
