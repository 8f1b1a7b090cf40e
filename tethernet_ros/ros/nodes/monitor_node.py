"""Capture-monitor node: CQI terms, locked pairs and the verdict from received states.

Subscribes  EpisodeSetup, LaunchCommand, ClosingCommand (to build the episode's
            StateMirror: same design, commands and configuration as the simulation) and
            NetState.
Publishes   CaptureMetrics for every state, and the monitor's EpisodeResult (topic
            ``verdict``, latched) when a state ends the episode: settle time after closing, the
            horizon, or divergence.

All numbers come from the core through :class:`tethernet_ros.monitoring.StateMirror`
(the one CQI function, the core's success rule); none is re-implemented here.
"""
from __future__ import annotations

from collections import deque

from rclpy.node import Node

from ...monitoring import StateMirror
from .. import conversions as conv
from ..parameters import declare, param, topic
from ..qos import ALIVE_LEASE_S, alive_qos, command_qos, latched_qos, state_qos
from ..runner import run_node
from ..state import CommandBuffer, SetupsHeard

NODE = "monitor_node"
MAX_PENDING = 10000


class MonitorNode(Node):
    def __init__(self):
        from tethernet_msgs.msg import CaptureMetrics, ClosingCommand, EpisodeResult, \
            EpisodeSetup, LaunchCommand, NetState

        super().__init__(NODE)
        declare(self, NODE)
        t = lambda k: topic(self, k)  # noqa: E731
        sq, cq = state_qos(int(param(self, "queue_depth"))), command_qos()
        self.frame_id = param(self, "frame_id")
        self._warm_up()
        self.pub_metrics = self.create_publisher(CaptureMetrics, t("metrics"),   # names.WATCHED
                                                 alive_qos(sq, ALIVE_LEASE_S))
        self.pub_verdict = self.create_publisher(EpisodeResult, t("verdict"), latched_qos())
        self.setup = None
        self.setups = SetupsHeard()
        self.commands = CommandBuffer()
        self.mirror: StateMirror | None = None
        self.decided = False
        self.pending: deque = deque(maxlen=MAX_PENDING)
        self.create_subscription(EpisodeSetup, t("setup"), self.on_setup, cq)
        self.create_subscription(LaunchCommand, t("launch_command"), self.on_launch, cq)
        self.create_subscription(ClosingCommand, t("closing_command"), self.on_closing, cq)
        self.create_subscription(NetState, t("net_state"), self.on_state, sq)
        self.get_logger().info("ready")

    @staticmethod
    def _warm_up() -> None:
        """Load the core's compiled helpers now, not while the first episode's states queue."""
        from ...core.config import SimConfig
        from ...core.design import REFERENCE_DESIGNS
        from ...core.scenario import actions_for, world_for

        d = REFERENCE_DESIGNS["baseline"]
        mirror = StateMirror(d, actions_for(d, None), world_for(d, None), SimConfig())
        mirror.terms()
        mirror.verdict()

    def on_setup(self, msg) -> None:
        if self.setups.repeat(msg):
            return                           # a repeat (the setup handshake, docs/ros.md)
        try:
            self.setup = conv.setup_from_msg(msg)
        except Exception as exc:  # noqa: BLE001
            self.get_logger().error(f"episode {msg.episode_id!r} rejected: {exc}")
            self.setup = None
        self.mirror = None
        self.decided = False
        self.pending.clear()
        self._maybe_build()

    def on_launch(self, msg) -> None:
        self.commands.put(msg.header, "launch", msg)
        self._maybe_build()

    def on_closing(self, msg) -> None:
        self.commands.put(msg.header, "closing", msg)
        self._maybe_build()

    def _maybe_build(self) -> None:
        if self.setup is None or self.mirror is not None:
            return
        launch, closing = self.commands.get(self.setup.stamp)
        if launch is None or closing is None:
            return
        try:
            actions, world = conv.commands_from_msgs(launch, closing)
            self.mirror = StateMirror(self.setup.design, actions, world, self.setup.config)
        except Exception as exc:  # noqa: BLE001
            self.get_logger().error(f"episode {self.setup.episode_id!r}: {exc}")
            return
        while self.pending:
            self._process(self.pending.popleft())

    def on_state(self, msg) -> None:
        if self.mirror is None:
            # a state can overtake the commands (different writers): keep it for later
            if self.setup is not None:
                self.pending.append(msg)
            return
        self._process(msg)

    def _process(self, msg) -> None:
        mirror = self.mirror
        try:
            mirror.load(conv.net_state_from_msg(msg))
        except Exception as exc:  # noqa: BLE001
            self.get_logger().error(f"state at step {msg.step} ignored: {exc}")
            return
        self.pub_metrics.publish(conv.metrics_msg(mirror.terms(), msg.sim_time,
                                                     mirror.locked_pairs, mirror.closing_active,
                                                     self.frame_id))
        if self.decided:
            return
        result = mirror.verdict()
        if result is None:
            return
        self.decided = True
        result.seed = self.setup.seed
        self.pub_verdict.publish(conv.episode_result_msg(result, self.setup.episode_id,
                                                            self.setup.seed is None, msg.sim_time,
                                                            seed=self.setup.request_seed))
        self.get_logger().info(f"episode {self.setup.episode_id!r}: verdict "
                               f"{'success' if result.success else 'failure'} at t = {msg.sim_time:.3f} s")


def main(args=None) -> int:
    return run_node(MonitorNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
