"""A test's view of a suite's ROS graph (a node on a private context, spun on demand),
and nodes started as processes, for the tests of the ROS side."""
from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter_client import AsyncParameterClient


class Graph:
    """A test node on a private context in ``domain``, spun on demand."""

    def __init__(self, domain: int, name: str = "tethernet_test_graph"):
        self.context = rclpy.Context()
        self.context.init(domain_id=domain)
        self.node = rclpy.create_node(name, context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)

    def spin_until(self, predicate, timeout: float = 30.0) -> bool:
        deadline = time.monotonic() + timeout
        while not predicate() and time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.02)
        return bool(predicate())

    def result(self, future, timeout: float = 30.0):
        assert self.spin_until(future.done, timeout), "no answer"
        return future.result()

    def ask(self, send, *args, timeout: float = 30.0, each: float = 5.0):
        """The answer to an idempotent request, sent by ``send(*args)`` (which returns its
        future) again every ``each`` s until one answers or ``timeout`` s pass.  A service
        can answer before it has matched the client's response reader, and that response
        is lost (ros2/rmw_cyclonedds#74; seen once in CI on a parameter request): a request
        sent once can wait for ever on a loaded machine."""
        deadline = time.monotonic() + timeout
        while True:
            future = send(*args)
            if self.spin_until(future.done, min(each, max(deadline - time.monotonic(), 0.0))):
                return future.result()
            assert time.monotonic() < deadline, f"no answer within {timeout:g} s"

    def names(self) -> set[str]:
        return {(ns.rstrip("/") + "/" + n) for n, ns in self.node.get_node_names_and_namespaces()}

    def params(self, remote: str) -> AsyncParameterClient:
        client = AsyncParameterClient(self.node, remote)
        assert self.spin_until(client.services_are_ready), f"no parameter services of {remote}"
        return client

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        self.context.try_shutdown()


def start_node(name: str, args: list[str], env: dict, log: Path) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", f"tethernet_ros.ros.nodes.{name}", "--ros-args", *args],
        stdout=open(log, "wb"), stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, env=env,
        start_new_session=True)


def stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def private_domain(offset: int) -> int:
    return (os.getpid() + offset) % 100 + 1
