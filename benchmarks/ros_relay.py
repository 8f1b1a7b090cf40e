"""The floor of the lockstep loop: a minimal rclpy exchange of three messages, the same
pattern as a control step (sim_node -> sensor_node -> controller -> sim_node).

    .venv/bin/python benchmarks/ros_relay.py relay IN OUT    # one hop: IN -> OUT (a process)
    .venv/bin/python benchmarks/ros_relay.py floor [--n 500] [--listeners K]
                                                              # start two hops, time round trips
    .venv/bin/python benchmarks/ros_relay.py listen           # a recorder's share: hears all three

``floor`` starts two relay processes (IN -> OUT, republished unchanged: a Measurement, as
the sensor node forwards one; then the controller's hop, a Measurement answered with a
ClosingDecision), publishes a Measurement and waits for the decision, ``--n`` times, in
nodes spun like the suite's (``runner.run_node``: a single-threaded executor), with the
suite's state QoS.  It prints the median and 95th percentile of the round trip (ms).
``--listeners K`` also starts K processes that subscribe to all three topics as the
capture node's recorder does (raw), since the suite records every loop message.  Used by
bench_ros.py; no asserts.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")

TOPICS = ("/bench_relay/truth", "/bench_relay/measurement", "/bench_relay/decision")


def _hop_node(name: str, wire):
    """A node ``name`` whose ``wire(node)`` creates its publishers and subscriptions."""
    import rclpy

    node = rclpy.create_node(name)
    wire(node)
    return node


def relay(src: str, dst: str) -> int:
    """One hop: republish every Measurement of ``src`` on ``dst`` (a Measurement, or a
    ClosingDecision when ``dst`` is the last topic), until SIGINT or SIGTERM; spun as the
    suite's nodes are (``runner.run_node``, a single-threaded executor)."""
    from tethernet_msgs.msg import ClosingDecision, Measurement

    from tethernet_ros.ros.qos import state_qos
    from tethernet_ros.ros.runner import run_node

    decides = dst == TOPICS[-1]

    def wire(node):
        pub = node.create_publisher(ClosingDecision if decides else Measurement, dst,
                                    state_qos())

        def forward(msg):
            if decides:
                out = ClosingDecision()
                out.header, out.episode_id, out.step = msg.header, msg.episode_id, msg.step
                pub.publish(out)
            else:
                pub.publish(msg)

        node.create_subscription(Measurement, src, forward, state_qos())

    return run_node(lambda: _hop_node(f"relay_{dst.rsplit('/', 1)[1]}", wire), [])


def listen() -> int:
    """Hear all three topics, raw, as the suite's recorder does, until SIGINT or SIGTERM."""
    from tethernet_msgs.msg import ClosingDecision, Measurement

    from tethernet_ros.ros.qos import state_qos
    from tethernet_ros.ros.runner import run_node

    def wire(node):
        for topic, kind in zip(TOPICS, (Measurement, Measurement, ClosingDecision)):
            node.create_subscription(kind, topic, lambda data: None, state_qos(), raw=True)

    return run_node(lambda: _hop_node("relay_listener", wire), [])


def floor(n: int = 500, warm: int = 50, listeners: int = 0) -> dict:
    """Round trips of three messages through two relay processes: {'median_ms', 'p95_ms',
    'n'} (the first ``warm`` left out)."""
    import threading

    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from tethernet_msgs.msg import ClosingDecision, Measurement

    from tethernet_ros.ros.qos import state_qos

    procs = [subprocess.Popen([sys.executable, __file__, "relay", TOPICS[i], TOPICS[i + 1]],
                              cwd=ROOT) for i in range(2)]
    procs += [subprocess.Popen([sys.executable, __file__, "listen"], cwd=ROOT)
              for _ in range(listeners)]
    if listeners:
        time.sleep(3.0)                           # (matched before the timing starts)
    rclpy.init()
    node = rclpy.create_node("relay_client")
    pub = node.create_publisher(Measurement, TOPICS[0], state_qos())
    got = threading.Event()
    node.create_subscription(ClosingDecision, TOPICS[2], lambda m: got.set(), state_qos())
    ex = SingleThreadedExecutor()
    ex.add_node(node)
    times = []
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:        # the relays started and matched
            msg = Measurement()
            got.clear()
            pub.publish(msg)
            t = time.monotonic()
            while not got.is_set() and time.monotonic() - t < 0.5:
                ex.spin_once(timeout_sec=0.05)
            if got.is_set():
                break
        for i in range(n + warm):
            msg = Measurement()
            msg.step = i
            got.clear()
            t = time.perf_counter()
            pub.publish(msg)
            while not got.is_set():
                ex.spin_once(timeout_sec=1.0)
            if i >= warm:
                times.append(time.perf_counter() - t)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
        for p in procs:
            p.terminate()
        for p in procs:
            p.wait(timeout=10)
    times.sort()
    return {"median_ms": 1e3 * times[len(times) // 2],
            "p95_ms": 1e3 * times[int(0.95 * (len(times) - 1))], "n": len(times)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="what", required=True)
    r = sub.add_parser("relay")
    r.add_argument("src")
    r.add_argument("dst")
    f = sub.add_parser("floor")
    f.add_argument("--n", type=int, default=500)
    f.add_argument("--listeners", type=int, default=0)
    sub.add_parser("listen")
    args = ap.parse_args(argv)
    if args.what == "relay":
        return relay(args.src, args.dst)
    if args.what == "listen":
        return listen()
    res = floor(args.n, listeners=args.listeners)
    print(f"minimal rclpy round trip of three messages ({res['n']}): median "
          f"{res['median_ms']:.2f} ms, 95th percentile {res['p95_ms']:.2f} ms")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
