"""`tethernet` command line: one subcommand per module in ``tethernet_ros.commands``.

Each command module defines ``NAME``, ``HELP``, ``add_arguments(parser)`` and
``run(args) -> int``.  Errors the user can fix (a bad design, a missing file) are printed
as one line naming the field and what is allowed, with exit status 2 and no traceback.
"""
from __future__ import annotations

import argparse
import importlib
import sys
import warnings

from .errors import UserError

#: command modules, in the order ``tethernet --help`` lists them
COMMANDS = ("capture", "validate", "sensitivity", "figures", "replay", "optimize", "study")


def _user_errors() -> tuple[type[BaseException], ...]:
    from .core.config import ConfigError
    from .core.design import DesignError
    from .core.noise import NoiseError

    return (UserError, DesignError, ConfigError, NoiseError, FileNotFoundError)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="tethernet", description="Tether-net capture design tool")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in COMMANDS:
        try:
            mod = importlib.import_module(f"tethernet_ros.commands.{name}")
        except ModuleNotFoundError as exc:
            if exc.name and exc.name.startswith("tethernet_ros.commands"):
                continue  # command not built yet
            raise
        text = mod.HELP.replace("%", "%%")  # argparse formats help strings with %
        p = sub.add_parser(mod.NAME, help=text, description=mod.HELP)
        mod.add_arguments(p)
        p.set_defaults(_run=mod.run)
    return parser


def _one_line_warning(message, category, filename, lineno, line=None) -> str:
    """A warning as the command's one line (not Python's two with the source line)."""
    return f"warning: {message}\n"


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    warnings.formatwarning = _one_line_warning
    try:
        return int(args._run(args) or 0)
    except _user_errors() as exc:
        print(f"tethernet {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"tethernet {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
