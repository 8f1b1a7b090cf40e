"""Run a user's controller node class as a process of its own:

    python -m tethernet_ros.ros.controller_host package.module:ClassName [--ros-args ...]

The class must be an rclpy ``Node`` whose constructor takes no argument (as the example,
:mod:`tethernet_ros.ros.examples.lead_controller`, is); it is built and spun like the
suite's own nodes (``runner.run_node``: clean exit on SIGINT and SIGTERM).  This is how
``RosSuite(controller="module:Class")`` and ``tethernet ... --controller module:Class``
start it; a console script is started as it is.
"""
from __future__ import annotations

import importlib
import sys

from .runner import run_node


def load_controller(spec: str):
    """The Node class named by ``module:Class``; ValueError (one line) if there is none."""
    module_name, _, class_name = spec.partition(":")
    if not module_name or not class_name:
        raise ValueError(f"controller {spec!r}: expected module:Class")
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise ValueError(f"controller {spec!r}: cannot import {module_name!r} ({exc})") from None
    cls = getattr(module, class_name, None)
    from rclpy.node import Node

    if not (isinstance(cls, type) and issubclass(cls, Node)):
        raise ValueError(f"controller {spec!r}: {class_name!r} is not an rclpy Node class "
                         f"of {module_name!r}")
    return cls


def main(argv=None) -> int:
    argv = list(sys.argv if argv is None else argv)
    if len(argv) < 2 or argv[1].startswith("-"):
        print("usage: python -m tethernet_ros.ros.controller_host module:Class [--ros-args ...]",
              file=sys.stderr)
        return 2
    try:
        cls = load_controller(argv[1])
    except ValueError as exc:
        print(f"controller_host: error: {exc}", file=sys.stderr)
        return 1
    return run_node(cls, [argv[0], *argv[2:]])


if __name__ == "__main__":
    raise SystemExit(main())
