"""Actuator node: nominal design + seed + noise settings -> noisy launch and closing
commands; in lockstep episodes also the closing policy.

Subscribes  EpisodeSetup; the sensed Measurement (``builtin_policy`` only).
Publishes   LaunchCommand (noisy corner-mass launch velocities, the target placement and
            tumble of the same draw, and the draw itself with its spreads) and
            ClosingCommand (noisy closing displacement), both stamped with the setup's
            stamp, before the simulation starts; in lockstep episodes a LaunchDecision
            for every Measurement before the launch and a ClosingDecision for every one
            after it (``builtin_policy`` only).

The noise is drawn by the core's single sampler, ``NoiseModel.sample(seed)``, with the
spreads of this node's ``noise.*`` parameters and the setup's scale factors; the draw is
split with the core's ``actions_for`` (the actuator's share) and ``world_for`` with the
configured tumble (the world's share, which the suite emulates by sending it along with
the launch).  In a lockstep episode (:func:`..loop.runs_in_lockstep`) the policy of the
episode's configuration (threshold or adaptive) runs here, as the core's ``Policy``, on
the sensor node's measurements: the same decisions as the kernel's own, bit for bit.
With ``builtin_policy`` false, or the policy 'external', another node answers (a user's
controller, docs/ros.md).
"""
from __future__ import annotations

from rclpy.node import Node

from ...core.scenario import actions_for, world_for
from .. import conversions as conv
from ..loop import (builtin_controller, episode_launch_policy, episode_policy, episode_scenario,
                    runs_in_lockstep)
from ..parameters import declare, node_spreads, param, topic
from ..qos import ALIVE_LEASE_S, alive_qos, command_qos, state_qos
from ..runner import run_node, wait_for_subscribers
from ..state import SetupsHeard

NODE = "actuator_node"


class ActuatorNode(Node):
    def __init__(self):
        from tethernet_msgs.msg import ClosingCommand, ClosingDecision, EpisodeSetup, \
            LaunchCommand, LaunchDecision, Measurement

        super().__init__(NODE)
        declare(self, NODE)
        t = lambda k: topic(self, k)  # noqa: E731
        cq = command_qos()
        self.pub_launch = self.create_publisher(LaunchCommand, t("launch_command"),  # WATCHED
                                                alive_qos(command_qos(), ALIVE_LEASE_S))
        self.pub_closing = self.create_publisher(ClosingCommand, t("closing_command"), cq)
        self.create_subscription(EpisodeSetup, t("setup"), self.on_setup, cq)
        self.builtin = bool(param(self, "builtin_policy"))
        self.pub_decision = self.pub_launch_decision = None
        # (episode id, Policy or None, its name, LaunchPolicy or None, its name)
        self.episode = None
        # the setups handled and the commands sent for the latest: a repeat of that setup
        # (the setup handshake, docs/ros.md) sends the same commands again
        self.setups = SetupsHeard()
        self.sent: tuple = ()
        if self.builtin:
            self._warm_up()
            sq = state_qos()
            self.pub_decision = self.create_publisher(ClosingDecision, t("closing_decision"), sq)
            self.pub_launch_decision = self.create_publisher(LaunchDecision,
                                                             t("launch_decision"), sq)
            self.create_subscription(Measurement, t("measurement"), self.on_measurement, sq)
        self.get_logger().info("ready" + ("" if self.builtin else
                                          " (no built-in policy: another node decides)"))

    @staticmethod
    def _warm_up() -> None:
        """Load the policy's compiled function now, not at the first measurement."""
        from ...core.design import REFERENCE_DESIGNS
        from ...core.policies import Policy
        from ...core.scenario import scenario_for
        from ...core.sensing import N_CHANNELS

        import numpy as np

        sc = scenario_for(REFERENCE_DESIGNS["baseline"])
        Policy(sc.kernel()[0], sc.close_threshold).decide(np.zeros(N_CHANNELS))

    def on_setup(self, msg) -> None:
        log = self.get_logger()
        if self.setups.repeat(msg):
            if self.setups.is_latest(msg):
                for pub, command in self.sent:   # lost on the way, maybe: the same again
                    pub.publish(command)
            return
        self.sent = ()
        try:
            setup = conv.setup_from_msg(msg)
            model = setup.noise_model(node_spreads(self))
            sample = None if model is None else model.sample(setup.seed)
            actions = actions_for(setup.design, sample)
            world = world_for(setup.design, sample, setup.config.tumble)
            policy, name, launch_policy, launch_name = None, "", None, ""
            if self.builtin and runs_in_lockstep(setup):
                scenario = episode_scenario(setup, actions, world)
                policy = episode_policy(setup, scenario)
                name = builtin_controller(self.get_name(), setup.config.policy.kind)
                launch_policy = episode_launch_policy(setup, scenario)
                launch_name = builtin_controller(self.get_name(), setup.config.launch.kind)
        except Exception as exc:  # noqa: BLE001 - logged; the episode never starts
            log.error(f"episode {msg.episode_id!r} rejected: {exc}")
            return
        self.episode = (setup.episode_id, policy, name, launch_policy, launch_name)
        frame = param(self, "frame_id")
        n = int(param(self, "min_command_subscribers"))
        timeout = float(param(self, "match_timeout"))
        pubs = [(self.pub_launch, n), (self.pub_closing, n)]
        if policy is not None:
            pubs.append((self.pub_decision, 0))      # (every one the graph shows)
        if launch_policy is not None:
            pubs.append((self.pub_launch_decision, 0))
        for pub, least in pubs:
            want = max(least, self.count_subscribers(pub.topic_name))
            if not wait_for_subscribers(pub, want, timeout, self.context):
                log.warning(f"{pub.topic_name}: {pub.get_subscription_count()} subscriber(s), "
                            f"expected {want}")
        self.sent = ((self.pub_launch, conv.launch_command_msg(actions, world, setup.seed,
                                                               setup.stamp, frame, sample, model)),
                     (self.pub_closing, conv.closing_command_msg(actions, setup.stamp, frame)))
        for pub, command in self.sent:
            pub.publish(command)
        log.info(f"episode {setup.episode_id!r}: commands sent "
                 f"({'nominal' if sample is None else f'seed {setup.seed}'})"
                 + (f"; closing policy {setup.config.policy.kind}" if policy is not None else "")
                 + (f"; launch policy {setup.config.launch.kind}" if launch_policy is not None
                    else ""))

    def on_measurement(self, msg) -> None:
        """Answer a measurement of the current lockstep episode with the policy's decision:
        before the launch the launch policy's, after it the closing policy's."""
        if self.episode is None or msg.episode_id != self.episode[0]:
            return
        _, policy, name, launch_policy, launch_name = self.episode
        values = conv.measurement_from_msg(msg)
        if not msg.launched:
            if launch_policy is None:
                return                   # not ours to answer (a user's controller decides)
            fire = launch_policy.decide(values, msg.age, msg.step)
            self.pub_launch_decision.publish(conv.launch_decision_msg(msg, fire, launch_name))
            return
        if policy is None:
            return
        close = values is not None and policy.decide(values)
        self.pub_decision.publish(conv.decision_msg(msg, close, name))


def main(args=None) -> int:
    return run_node(ActuatorNode, args, events=True)


if __name__ == "__main__":
    raise SystemExit(main())
