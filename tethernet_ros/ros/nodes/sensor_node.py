"""Sensor node: what the chaser senses of the truth, in lockstep episodes.

Subscribes  EpisodeSetup, LaunchCommand and ClosingCommand (to build the episode's sensor:
            the same scenario, sensing settings and seed as the simulation's), and the true
            Measurement the simulation publishes at every control step.
Publishes   for every true measurement, the sensed Measurement (``valid`` false while none
            has reached the controller yet: the sensing latency), which a controller
            answers; and for every valid one the sensed state in standard messages: the
            target's pose (geometry_msgs/PoseWithCovarianceStamped), its twist
            (TwistWithCovarianceStamped) and the net's reference point (PointStamped),
            with the covariances of the sensor's noise (conversions.sensed_msgs).

The noise, buffer and latency are the core's ``Sensor`` (``core.sensing``), seeded with
the episode's seed: the same sensed measurements as inside the kernel, bit for bit.  A
true measurement that comes before the episode's commands is kept until they are in.
"""
from __future__ import annotations

import time
from collections import deque

from rclpy.node import Node

from .. import conversions as conv
from ..loop import episode_scenario, episode_sensor, runs_in_lockstep
from ..parameters import declare, param, topic
from ..qos import ALIVE_LEASE_S, alive_qos, command_qos, state_qos
from ..runner import run_node, wait_for_subscribers
from ..state import CommandBuffer, SetupsHeard

NODE = "sensor_node"
MAX_PENDING = 10000


class SensorNode(Node):
    def __init__(self):
        from geometry_msgs.msg import PointStamped, PoseWithCovarianceStamped, \
            TwistWithCovarianceStamped
        from tethernet_msgs.msg import ClosingCommand, EpisodeSetup, LaunchCommand, Measurement

        super().__init__(NODE)
        declare(self, NODE)
        t = lambda k: topic(self, k)  # noqa: E731
        sq, cq = state_qos(int(param(self, "queue_depth"))), command_qos()
        self.frame_id = param(self, "frame_id")
        self._warm_up()
        self.pub_measurement = self.create_publisher(Measurement, t("measurement"),  # WATCHED
                                                     alive_qos(sq, ALIVE_LEASE_S))
        self.pub_pose = self.create_publisher(PoseWithCovarianceStamped,
                                              t("sensed_target_pose"), sq)
        self.pub_twist = self.create_publisher(TwistWithCovarianceStamped,
                                               t("sensed_target_twist"), sq)
        self.pub_point = self.create_publisher(PointStamped, t("sensed_net_point"), sq)
        self.setup = None
        self.setups = SetupsHeard()
        self.sensor = None
        self.dt = 0.0
        self.commands = CommandBuffer()
        self.pending: deque = deque(maxlen=MAX_PENDING)
        self.create_subscription(EpisodeSetup, t("setup"), self.on_setup, cq)
        self.create_subscription(LaunchCommand, t("launch_command"), self.on_launch, cq)
        self.create_subscription(ClosingCommand, t("closing_command"), self.on_closing, cq)
        self.create_subscription(Measurement, t("true_measurement"), self.on_truth, sq)
        self.get_logger().info("ready")

    @staticmethod
    def _warm_up() -> None:
        """Load the sensor's compiled functions now, not at the first measurement."""
        from ...core.design import REFERENCE_DESIGNS
        from ...core.scenario import scenario_for
        from ...core.sensing import N_CHANNELS, Sensor

        import numpy as np

        Sensor(scenario_for(REFERENCE_DESIGNS["baseline"]).control, 0).measure(
            np.zeros(N_CHANNELS), 0)

    def on_setup(self, msg) -> None:
        if self.setups.repeat(msg):
            return                           # a repeat (the setup handshake, docs/ros.md)
        try:
            self.setup = conv.setup_from_msg(msg)
        except Exception as exc:  # noqa: BLE001
            self.get_logger().error(f"episode {msg.episode_id!r} rejected: {exc}")
            self.setup = None
        self.sensor = None
        self.pending.clear()
        self._maybe_build()

    def on_launch(self, msg) -> None:
        self.commands.put(msg.header, "launch", msg)
        self._maybe_build()

    def on_closing(self, msg) -> None:
        self.commands.put(msg.header, "closing", msg)
        self._maybe_build()

    def _maybe_build(self) -> None:
        setup = self.setup
        if setup is None or self.sensor is not None or not runs_in_lockstep(setup):
            return
        launch, closing = self.commands.get(setup.stamp)
        if launch is None or closing is None:
            return
        try:
            actions, world = conv.commands_from_msgs(launch, closing)
            scenario = episode_scenario(setup, actions, world)
            self.sensor = episode_sensor(setup, scenario)
            self.dt = scenario.dt
        except Exception as exc:  # noqa: BLE001
            self.get_logger().error(f"episode {setup.episode_id!r}: {exc}")
            return
        # every subscriber the graph shows (the controller, the recorder) matched before
        # the first measurement goes out; match_timeout for the four topics together (the
        # simulation allows its own match_timeout more for the episode's first decision)
        # (the controller's own subscription may not be in this node's graph yet: the
        # measurement waits for min_measurement_subscribers at least; CI once lost an
        # episode's first measurement to a controller discovered late)
        deadline = time.monotonic() + float(param(self, "match_timeout"))
        least = {self.pub_measurement: int(param(self, "min_measurement_subscribers"))}
        for pub in (self.pub_measurement, self.pub_pose, self.pub_twist, self.pub_point):
            want = max(least.get(pub, 0), self.count_subscribers(pub.topic_name))
            if want and not wait_for_subscribers(pub, want, max(0.0, deadline - time.monotonic()),
                                                 self.context):
                self.get_logger().warning(f"{pub.topic_name}: {pub.get_subscription_count()} "
                                          f"of {want} subscribers matched at the start")
        while self.pending:
            self._sense(self.pending.popleft())

    def on_truth(self, msg) -> None:
        if self.setup is None or msg.episode_id != self.setup.episode_id:
            return
        if self.sensor is None:
            self.pending.append(msg)          # the truth overtook the commands: keep it
            return
        self._sense(msg)

    def _sense(self, msg) -> None:
        truth = conv.measurement_from_msg(msg)
        sim_time = conv.time_from_msg(msg.header.stamp)
        sensed = self.sensor.measure(truth, int(msg.step))
        age = self.sensor.age(msg.step, self.dt)
        out = conv.measurement_msg(sensed, msg.step, sim_time, msg.episode_id,
                                   msg.closing_displacement, self.frame_id,
                                   launched=msg.launched, age=age)
        out.header.stamp = msg.header.stamp           # exactly the truth's stamp
        # the measurement first: the controller, and so the simulation, waits for it; the
        # standard messages are for viewers and the bag (docs/ros.md, what lockstep costs)
        self.pub_measurement.publish(out)
        if sensed is not None:
            pose, twist, point = conv.sensed_msgs(sensed, sim_time, self.setup.config.sensing,
                                                  self.frame_id)
            for m in (pose, twist, point):
                m.header.stamp = msg.header.stamp
            self.pub_pose.publish(pose)
            self.pub_twist.publish(twist)
            self.pub_point.publish(point)


def main(args=None) -> int:
    return run_node(SensorNode, args, events=True)


if __name__ == "__main__":
    raise SystemExit(main())
