"""Errors shared by the CLI and the library."""


class UserError(Exception):
    """An error in what the user asked for; the CLI prints it as one line (exit status 2)."""
