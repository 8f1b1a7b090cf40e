"""`tethernet` command line: one subcommand per module in ``tethernet_ros.commands``.

Each command module defines ``NAME``, ``HELP``, ``add_arguments(parser)`` and
``run(args) -> int``.  Errors the user can fix (a bad design, a missing file) are printed
as one line naming the field and what is allowed, with exit status 2 and no traceback.
"""
from __future__ import annotations

import argparse
import importlib
import signal
import sys
import threading
import warnings

from .errors import UserError

#: command modules, in the order ``tethernet --help`` lists them
COMMANDS = ("capture", "validate", "sensitivity", "figures", "replay", "optimize", "cost",
            "study", "target")


def _user_errors() -> tuple[type[BaseException], ...]:
    from .core.config import ConfigError
    from .core.design import DesignError
    from .core.noise import NoiseError
    from .core.tug import TugError

    return (UserError, DesignError, ConfigError, NoiseError, TugError, FileNotFoundError)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="tethernet", description="Tether-net capture design tool")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in COMMANDS:
        # a command module that fails to import is an error, not a command left out
        mod = importlib.import_module(f"tethernet_ros.commands.{name}")
        text = mod.HELP.replace("%", "%%")  # argparse formats help strings with %
        p = sub.add_parser(mod.NAME, help=text, description=mod.HELP)
        mod.add_arguments(p)
        p.set_defaults(_run=mod.run)
    return parser


def _one_line_warning(message, category, filename, lineno, line=None) -> str:
    """A warning as the command's one line (not Python's two with the source line)."""
    return f"warning: {message}\n"


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread like Ctrl-C, so that a command stops as it does
    on Ctrl-C: its worker processes and ROS suites are stopped, what it finished is kept
    in its results file or run directory (resumable), and it exits with 143."""


def _raise_terminated(signum, frame):
    raise Terminated()


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    warnings.formatwarning = _one_line_warning
    previous = None
    if threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGTERM, _raise_terminated)
    try:
        return int(args._run(args) or 0)
    except _user_errors() as exc:
        print(f"tethernet {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        terminated = isinstance(exc, Terminated)
        print(f"tethernet {args.command}: {'terminated' if terminated else 'interrupted'}",
              file=sys.stderr)
        return 143 if terminated else 130
    finally:
        if previous is not None:               # main() called in-process (tests, scripts)
            signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":
    sys.exit(main())
