"""The nodes' main loop: init, spin, shut down cleanly on SIGINT and SIGTERM alike.

rclpy installs its own handlers for both signals (``SignalHandlerOptions.ALL``, asked for
explicitly here).  They run in C, so they work while an executor waits inside rcl: they
shut the context down and wake every executor, whose ``spin`` then ends with
ExternalShutdownException.  A Python ``signal.signal`` handler would replace rclpy's and
could only run between bytecodes of the main thread, which never happens while it waits
in C; so none is installed.  The executor waits at most POLL_S at a time, so that a
signal whose wake-up the executor misses still ends the node.  Work that runs inside a
callback for long (the capture node's episode) watches ``context.ok()`` and stops by
itself.  The node's ``close()`` then
ends its threads (and finishes or marks its bag), and the process exits with status 0 at
once (:func:`exit_process`): the interpreter's own finalization (numba, llvmlite, the ROS
libraries) took 0.4-0.6 s more, idle, and over 1 s under load.
"""
from __future__ import annotations

import faulthandler
import os
import signal
import sys
import time


#: s: the longest a node waits in its executor before it checks that its context is alive
POLL_S = 0.2


def spin_while_ok(executor, context) -> None:
    """Spin ``executor`` while ``context`` is alive, in waits of at most POLL_S, not
    ``executor.spin()``: now and then (about one stop in a hundred, measured under load)
    a signal shuts the context down but the executor's wait is never woken, and the node
    would hang in it; each wait ends after POLL_S and the loop sees the context gone."""
    while context.ok():
        executor.spin_once(timeout_sec=POLL_S)


def default_environment() -> None:
    """Keep DDS discovery on this host unless the environment says otherwise."""
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")


def wait_for_subscribers(publisher, count: int, timeout: float, context=None) -> bool:
    """Wait until ``publisher`` has matched ``count`` subscriptions (at most ``timeout``
    s; False also when ``context`` shuts down meanwhile)."""
    deadline = time.monotonic() + timeout
    while publisher.get_subscription_count() < count:
        if time.monotonic() > deadline or (context is not None and not context.ok()):
            return False
        time.sleep(0.01)
    return True


def exit_process(status: int) -> None:
    """End the process now with ``status``, without the interpreter's finalization: the
    node has closed everything it owns (its bag is finished or marked); what is left is
    to flush the standard streams and the ROS log."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
    try:
        from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy

        _rclpy.rclpy_logging_fini()
    except Exception:  # noqa: BLE001 - nothing to flush
        pass
    os._exit(status)


def _shutdown_artefact(exc: Exception) -> bool:
    """Whether ``exc`` is what a callback meets when the context shut down under it
    (rcl: "publisher's context is invalid", "context is not valid")."""
    text = str(exc).lower()
    return "context is invalid" in text or "context is not valid" in text \
        or "invalid context" in text


def _failed(node, factory, exc: Exception) -> int:
    """Report a node's failure in one line on stderr; the exit status, 1."""
    if os.environ.get("TETHERNET_DEBUG"):
        import traceback

        traceback.print_exc()
    # before the node exists: the NODE name of its module (nodes/<node>.py)
    name = node.get_name() if node is not None else \
        getattr(sys.modules.get(getattr(factory, "__module__", "")), "NODE", "node")
    print(f"{name}: error: {exc}", file=sys.stderr)
    return 1


def run_node(factory, args=None, threads: int = 1, exit_now: bool = True,
             events: bool = False) -> int:
    """Init rclpy, build the node with ``factory()``, spin it until SIGINT, SIGTERM or
    shutdown, then ``node.close()`` (if it has one).  ``threads`` > 1: a multi-threaded
    executor; ``events``: rclpy's C++ events executor (rclpy.experimental), for the nodes
    on the lockstep loop's path (sim, sensor, actuator): a control step costs 1.9-2.8 ms
    with it against 2.5-3.6 ms with the Python single-threaded executor (docs/ros.md).  The process exit status: 0 on a
    clean shutdown, 1 with one line on stderr if the node failed; with ``exit_now`` (a
    node's process) the process ends with it at once (:func:`exit_process`), otherwise it
    is returned."""
    default_environment()
    # every thread's Python stack on stderr at SIGUSR1: a hung node can be asked where it is
    faulthandler.register(signal.SIGUSR1, all_threads=True)
    import rclpy
    from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor, \
        SingleThreadedExecutor
    from rclpy.signals import SignalHandlerOptions

    rclpy.init(args=args if args is not None else sys.argv,
               signal_handler_options=SignalHandlerOptions.ALL)
    node = None
    status = 0
    try:
        node = factory()
        if events:
            from rclpy.experimental import EventsExecutor

            executor = EventsExecutor(context=node.context)
        elif threads > 1:
            executor = MultiThreadedExecutor(num_threads=threads)
        else:
            executor = SingleThreadedExecutor()
        executor.add_node(node)
        try:
            spin_while_ok(executor, node.context)
        finally:
            executor.shutdown(timeout_sec=1.0)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except Exception as exc:  # noqa: BLE001 - one line on stderr, non-zero status
        if node is not None and not node.context.ok() and _shutdown_artefact(exc):
            pass                             # a callback overtaken by SIGINT / SIGTERM
        else:
            status = _failed(node, factory, exc)
    finally:
        if node is not None:
            close = getattr(node, "close", None)
            if close is not None:
                close()
            node.destroy_node()
        rclpy.try_shutdown()
    if exit_now:
        exit_process(status)
    return status
