"""Actuator node: nominal design + seed + noise settings -> noisy launch and closing commands.

Subscribes  EpisodeSetup.
Publishes   LaunchCommand (noisy corner-mass launch velocities, and the target placement of
            the same draw) and ClosingCommand (noisy closing displacement), both stamped
            with the setup's stamp, before the simulation starts.

The noise is drawn by the core's single sampler, ``NoiseModel.sample(seed)``, with the
spreads of this node's ``noise.*`` parameters and the setup's scale factors; the draw is
split with the core's ``actions_for`` (the actuator's share) and ``world_for`` (the
world's share, which the suite emulates by sending it along with the launch).
"""
from __future__ import annotations

from rclpy.node import Node

from ...core.scenario import actions_for, world_for
from .. import conversions as conv
from ..parameters import declare, node_spreads, param, topic
from ..qos import command_qos
from ..runner import run_node, wait_for_subscribers

NODE = "actuator_node"


class ActuatorNode(Node):
    def __init__(self):
        from tethernet_msgs.msg import ClosingCommand, EpisodeSetup, LaunchCommand

        super().__init__(NODE)
        declare(self, NODE)
        t = lambda k: topic(self, k)  # noqa: E731
        cq = command_qos()
        self.pub_launch = self.create_publisher(LaunchCommand, t("launch_command"), cq)
        self.pub_closing = self.create_publisher(ClosingCommand, t("closing_command"), cq)
        self.create_subscription(EpisodeSetup, t("setup"), self.on_setup, cq)
        self.get_logger().info("ready")

    def on_setup(self, msg) -> None:
        log = self.get_logger()
        try:
            setup = conv.setup_from_msg(msg)
            model = setup.noise_model(node_spreads(self))
            sample = None if model is None else model.sample(setup.seed)
            actions = actions_for(setup.design, sample)
            world = world_for(setup.design, sample)
        except Exception as exc:  # noqa: BLE001 - logged; the episode never starts
            log.error(f"episode {msg.episode_id!r} rejected: {exc}")
            return
        frame = param(self, "frame_id")
        n = int(param(self, "min_command_subscribers"))
        timeout = float(param(self, "match_timeout"))
        for pub in (self.pub_launch, self.pub_closing):
            if not wait_for_subscribers(pub, n, timeout, self.context):
                log.warning(f"{pub.topic_name}: {pub.get_subscription_count()} subscriber(s), "
                            f"expected {n}")
        self.pub_launch.publish(conv.launch_command_msg(actions, world, setup.seed,
                                                           setup.stamp, frame))
        self.pub_closing.publish(conv.closing_command_msg(actions, setup.stamp, frame))
        log.info(f"episode {setup.episode_id!r}: commands sent "
                 f"({'nominal' if sample is None else f'seed {setup.seed}'})")


def main(args=None) -> int:
    return run_node(ActuatorNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
