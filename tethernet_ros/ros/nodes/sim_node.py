"""Simulation node: owns the scenario and the numba kernel of one episode at a time.

Subscribes  EpisodeSetup (design, seed, configuration), LaunchCommand and ClosingCommand
            (the actuator's noisy actions, target placement and tumble; matched to the
            setup by header stamp), the cancel topic (std_msgs/String: the id of an
            episode to stop, sent when a Capture goal is canceled), and in lockstep
            episodes the controller's ClosingDecision.
Publishes   NetState, target PoseStamped and /clock every ``publish_rate`` Hz of simulated
            time, a MarkerArray every ``marker_rate`` Hz, and at the end the simulation's
            EpisodeResult (latched: transient-local, depth 1); in lockstep episodes also
            /clock and the true Measurement at every control step.

The episode is run by the core's ``run_simulation`` on a CaptureSimulation whose
``advance`` publishes at the publish steps on the way; ``advance`` is chunking-invariant,
so the states and the result are bit for bit those of ``tethernet capture --via library``.
By default the closing policy runs inside the kernel from the ClosingCommand's threshold,
which arrives before the first step, so nothing depends on message timing.  In a lockstep
episode (:func:`..loop.runs_in_lockstep`) the kernel's policy is 'external' and
``advance`` also stops at every control step: it publishes /clock and the true
measurement and waits (``decision_timeout`` s at most; before the controller's first
decision of an episode, ``match_timeout`` s more) for the ClosingDecision of that
step, from the controller behind the sensor node, before it goes on; a decision to close
is commanded at that step, as the kernel's own policy would start it
(:class:`..loop.ControlledSimulation`).  A controller that does not answer in time ends the
episode with a result whose failure reason starts with names.CONTROLLER_TIMEOUT (the
capture node answers ABORTED with it), and the node serves the next episode.

The episode thread only copies the state at a publish step; the outbox thread
(:mod:`..publishing`) builds and publishes the messages in order; the result is published
after every state.  A canceled episode, or one still running when the next EpisodeSetup
arrives (the capture node gave up on it), stops at its next publish step and publishes
no result; on shutdown (SIGINT, SIGTERM) the episode stops likewise and the node exits.
"""
from __future__ import annotations

import sys
import threading
import time

from rclpy.node import Node

from ...core.episode import CaptureSimulation, episode_result, run_simulation
from ...core.kernel.model import steps_every
from .. import conversions as conv
from ..loop import ControllerConflict, ControllerTimeout, LoopFailure, episode_scenario, \
    kernel_config, runs_in_lockstep, step_time_summary, truth_of
from ..markers import MarkerBuilder
from ..names import CONTROLLER_TIMEOUT, TWO_CONTROLLERS
from ..parameters import declare, param, topic
from ..publishing import EpisodeAborted, Outbox, PublishingSimulation
from ..qos import ALIVE_LEASE_S, alive_qos, command_qos, latched_qos, state_qos
from ..runner import run_node, wait_for_subscribers
from ..state import CommandBuffer, SetupsHeard, state_arrays

NODE = "sim_node"


class SimNode(Node):
    def __init__(self):
        from tethernet_msgs.msg import ClosingCommand, ClosingDecision, EpisodeResult, \
            EpisodeSetup, LaunchCommand, LaunchDecision, Measurement, NetState
        from geometry_msgs.msg import PoseStamped
        from rosgraph_msgs.msg import Clock
        from std_msgs.msg import String
        from visualization_msgs.msg import MarkerArray

        super().__init__(NODE)
        # The episode thread needs the GIL between kernel calls (which release it); with
        # the default 5 ms switch interval it waits that long whenever the outbox thread is
        # building a message.  0.5 ms measured: 0.16 s instead of 0.34 s of such waits per
        # time-min capture.
        sys.setswitchinterval(0.0005)
        self.node = node = self
        declare(node, NODE)
        p = lambda k: param(node, k)  # noqa: E731
        self.frame_id = p("frame_id")
        if p("warm_up"):
            self._warm_up()
        depth = int(p("queue_depth"))
        sq, cq = state_qos(depth), command_qos()
        t = lambda k: topic(node, k)  # noqa: E731
        # (its liveliness shows the capture node that this node is alive: names.WATCHED)
        self.pub_state = node.create_publisher(NetState, t("net_state"),
                                               alive_qos(sq, ALIVE_LEASE_S))
        self.pub_pose = node.create_publisher(PoseStamped, t("target_pose"), sq)
        self.pub_clock = node.create_publisher(Clock, t("clock"), sq)
        self.pub_markers = node.create_publisher(MarkerArray, t("markers"), sq)
        self.pub_result = node.create_publisher(EpisodeResult, t("result"), latched_qos())
        self.pub_truth = node.create_publisher(Measurement, t("true_measurement"), sq)
        self._lock = threading.Lock()
        # the decision a lockstep episode waits for: (episode id, step, kind: 'launch' or
        # 'closing'), and its answer
        self._awaiting: tuple[str, int, str] | None = None
        self._answer = None
        self._answered = threading.Event()
        # the lockstep episode whose decisions are heard, the controllers they name and
        # the control steps decided, per kind of decision (one decider of each kind is
        # allowed: a second name, or a step decided twice, is a second node answering;
        # rclpy's message info does not carry the publisher)
        self._loop_episode: str | None = None
        self._deciders: dict[str, set[str]] = {}
        self._decided: set[tuple[str, int]] = set()
        self._twice: tuple[str, int] | None = None     # the first step decided twice
        self._setup = None
        self.setups = SetupsHeard()
        self._commands = CommandBuffer()
        self._worker: threading.Thread | None = None
        self._stop = threading.Event()
        self._running: tuple[str, threading.Event] | None = None   # (episode id, its stop)
        self._outbox = Outbox(node.get_logger())
        node.create_subscription(EpisodeSetup, t("setup"), self.on_setup, cq)
        node.create_subscription(LaunchCommand, t("launch_command"), self.on_launch, cq)
        node.create_subscription(ClosingCommand, t("closing_command"), self.on_closing, cq)
        node.create_subscription(String, t("cancel"), self.on_cancel, cq)
        self.sub_decision = node.create_subscription(ClosingDecision, t("closing_decision"),
                                                     self.on_decision, sq)
        self.sub_launch_decision = node.create_subscription(
            LaunchDecision, t("launch_decision"), self.on_launch_decision, sq)
        node.get_logger().info("ready")

    # -- parameters read at each episode (they may be changed between episodes) ----------
    def _p(self, key):
        return param(self.node, key)

    @staticmethod
    def _warm_up() -> None:
        """Load (or compile) the numba kernels now rather than in the first episode."""
        from ...core.design import REFERENCE_DESIGNS
        from ...core.scenario import scenario_for

        sim = CaptureSimulation(scenario_for(REFERENCE_DESIGNS["baseline"]))
        sim.advance(1)
        truth_of(sim)                        # (the lockstep episodes' true measurement)

    # -- callbacks ---------------------------------------------------------------------
    def on_setup(self, msg) -> None:
        log = self.node.get_logger()
        with self._lock:
            if self.setups.repeat(msg):
                return                       # a repeat (the setup handshake, docs/ros.md)
            if self._running is not None:
                # the capture node sends a setup only once it is done with the episode
                # before: that one is abandoned (timed out there); stop it, then start this
                log.warning(f"episode {self._running[0]!r} stopped: episode {msg.episode_id!r} "
                            "supersedes it")
                self._running[1].set()
            try:
                self._setup = conv.setup_from_msg(msg)
            except Exception as exc:  # noqa: BLE001 - a bad setup is logged, not fatal
                log.error(f"episode {msg.episode_id!r} rejected: {exc}")
                self._setup = None
                return
        self._maybe_start()

    def on_launch(self, msg) -> None:
        with self._lock:
            self._commands.put(msg.header, "launch", msg)
        self._maybe_start()

    def on_closing(self, msg) -> None:
        with self._lock:
            self._commands.put(msg.header, "closing", msg)
        self._maybe_start()

    def on_cancel(self, msg) -> None:
        """Stop the running episode if it is the one named (the capture node's cancel)."""
        with self._lock:
            if self._running is not None and self._running[0] == msg.data:
                self.node.get_logger().info(f"episode {msg.data!r}: canceled")
                self._running[1].set()

    def on_decision(self, msg) -> None:
        """The controller's ClosingDecision (:meth:`_heard`)."""
        self._heard(msg, "closing")

    def on_launch_decision(self, msg) -> None:
        """The controller's LaunchDecision (:meth:`_heard`)."""
        self._heard(msg, "launch")

    def _heard(self, msg, kind: str) -> None:
        """A decision of ``kind``: the answer if it is the one awaited.  A decision of
        another episode (a stale one) is ignored; one of this episode from a second
        decider of its kind ends the episode (:class:`..loop.ControllerConflict`)."""
        with self._lock:
            if msg.episode_id != self._loop_episode:
                return
            step = int(msg.step)
            deciders = self._deciders.setdefault(kind, set())
            deciders.add(msg.controller)
            if (kind, step) in self._decided and self._twice is None:
                self._twice = (kind, step)
            self._decided.add((kind, step))
            if len(deciders) > 1 or self._twice is not None:
                self._answered.set()         # the episode thread reports the conflict
                return
            if self._awaiting == (msg.episode_id, step, kind) and not self._answered.is_set():
                self._answer = msg
                self._answered.set()

    def _maybe_start(self) -> None:
        with self._lock:
            if self._setup is None or self._running is not None:
                return                       # (an episode that ends calls this again)
            launch, closing = self._commands.get(self._setup.stamp)
            if launch is None or closing is None:
                return
            setup = self._setup
            self._setup = None
            stop = threading.Event()
            self._running = (setup.episode_id, stop)
            self._worker = threading.Thread(target=self._episode, args=(setup, launch, closing, stop),
                                            name="episode", daemon=True)
            self._worker.start()

    def _episode(self, setup, launch, closing, stop: threading.Event) -> None:
        try:
            self._run_episode(setup, launch, closing, stop)
        finally:
            with self._lock:
                self._running = None
            if not self.stopping():
                self._maybe_start()          # a setup that came meanwhile

    # -- the episode -------------------------------------------------------------------
    def _run_episode(self, setup, launch, closing, stop: threading.Event) -> None:
        log = self.node.get_logger()
        lockstep = runs_in_lockstep(setup)
        try:
            actions, world = conv.commands_from_msgs(launch, closing)
            config = kernel_config(setup.config) if lockstep else setup.config
            scenario = episode_scenario(setup, actions, world, config)
        except Exception as exc:  # noqa: BLE001
            log.error(f"episode {setup.episode_id!r}: cannot build the scenario: {exc}")
            return
        dt = scenario.dt
        rate = float(self._p("publish_rate"))
        every = steps_every(rate, dt)                     # rate > 0: parameters.py
        mrate = float(self._p("marker_rate"))
        marker_every = steps_every(mrate, dt) if mrate > 0 else 0
        rtf = float(self._p("real_time_factor"))
        markers = MarkerBuilder(scenario, self.frame_id)
        t_wall0 = time.monotonic()
        marker_step = [-1]
        frame = self.frame_id
        outbox = self._outbox
        clock_step = [-1]                               # the last step on /clock

        def publish_clock(step, sim_time):             # runs in the outbox thread
            if step > clock_step[0]:
                clock_step[0] = step
                self.pub_clock.publish(conv.clock_msg(sim_time))

        def publish_states(state, with_markers):       # runs in the outbox thread
            if self.stopping() or stop.is_set():
                return
            publish_clock(state.step, state.sim_time)
            self.pub_state.publish(conv.net_state_msg(state, frame))
            self.pub_pose.publish(conv.target_pose_msg(state, frame))
            if with_markers:
                self.pub_markers.publish(markers.build(state))

        def publish(sim):                               # runs in the episode thread
            if rtf > 0:
                delay = t_wall0 + sim.time / rtf - time.monotonic()
                if delay > 0:
                    time.sleep(delay)
            with_markers = bool(marker_every) and sim.mission_step % marker_every == 0
            if with_markers:
                marker_step[0] = sim.mission_step
            state = state_arrays(sim)
            outbox.put(lambda: publish_states(state, with_markers))

        def publish_markers(sim):
            marker_step[0] = sim.mission_step
            state = state_arrays(sim)
            outbox.put(lambda: self.stopping() or self.pub_markers.publish(markers.build(state)))

        should_stop = lambda: stop.is_set() or self.stopping()  # noqa: E731
        controller = None
        loop_times: list[tuple[float, float]] = []
        if lockstep:
            controller = self._exchange(setup.episode_id, scenario.close_threshold,
                                        float(self._p("decision_timeout")),
                                        float(self._p("match_timeout")), should_stop,
                                        publish_clock, loop_times)
        sim = PublishingSimulation(scenario, every, publish, should_stop, controller)
        n_subs = int(self._p("min_state_subscribers"))
        timeout = float(self._p("match_timeout"))
        if not wait_for_subscribers(self.pub_state, n_subs, timeout, self.context):
            log.warning(f"starting with {self.pub_state.get_subscription_count()} state "
                        f"subscriber(s) (expected {n_subs})")
        # the other topics: wait until every subscriber the graph shows (the recorder, a
        # viewer, the sensor node) is matched, so that none misses the first messages
        # (the truth: min_truth_subscribers at least, the sensor node's subscription may
        # not be in this node's graph yet)
        pubs = [(self.pub_pose, 0), (self.pub_clock, 0), (self.pub_markers, 0)]
        if lockstep:
            pubs.append((self.pub_truth, int(self._p("min_truth_subscribers"))))
            self._wait_for_controller(timeout, not sim.launched)
        for pub, least in pubs:
            want = max(least, self.node.count_subscribers(pub.topic_name))
            if want and not wait_for_subscribers(pub, want, timeout, self.context):
                log.warning(f"{pub.topic_name}: {pub.get_subscription_count()} of {want} "
                            "subscribers matched at the start")
        log.info(f"episode {setup.episode_id!r}: dt = {dt:.3e} s, publishing every {every} steps"
                 + (f", closing decided through ROS every {sim.period} steps" if lockstep else ""))
        try:
            sim.publish()                                   # the initial state
            try:
                if lockstep:
                    sim.wait_for_launch()       # (immediate: it has left already)
                result = run_simulation(sim, record_trace=False)
                if lockstep:
                    self._check_deciders()   # a second one heard after the last step
            except LoopFailure as exc:
                result = episode_result(sim, str(exc))
                log.error(f"episode {setup.episode_id!r}: {exc}")
            sim.publish()                                   # the final state (if not yet)
            if marker_every and marker_step[0] != sim.mission_step:
                publish_markers(sim)                        # ... and its markers
            result.seed = setup.seed
            msg = conv.episode_result_msg(result, setup.episode_id, setup.seed is None, sim.time,
                                          seed=setup.request_seed)
            outbox.put(lambda: self.pub_result.publish(msg))
            outbox.drain()
        except EpisodeAborted:
            log.warning(f"episode {setup.episode_id!r} aborted at t = {sim.time:.3f} s")
            return
        except Exception as exc:  # noqa: BLE001 - e.g. publishing after shutdown began
            if not self.stopping():
                log.error(f"episode {setup.episode_id!r} failed at t = {sim.time:.3f} s: {exc}")
            return
        finally:
            with self._lock:
                self._awaiting = None
                self._loop_episode = None
        if lockstep and loop_times:
            log.info(f"episode {setup.episode_id!r}: {step_time_summary(loop_times)}")
        verdict = "success" if result.success else f"failure ({result.failure_reason})"
        log.info(f"episode {setup.episode_id!r} done: {verdict}, T = {result.completion_time:.3f} s, "
                 f"wall {result.wall_time:.2f} s")

    def _check_deciders(self) -> None:
        """Raise ControllerConflict if a second decider was heard in this episode (another
        controller name, or a step decided twice)."""
        with self._lock:
            deciders = {k: sorted(v) for k, v in self._deciders.items()}
            twice = self._twice
        for kind, names in sorted(deciders.items()):
            topic_name = (self.sub_decision if kind == "closing"
                          else self.sub_launch_decision).topic_name
            if len(names) > 1:
                who = f"{len(names)} controllers ({', '.join(repr(c) for c in names)})"
            elif twice is not None and twice[0] == kind:
                who = f"step {twice[1]} decided twice (by {names[0]!r})"
            else:
                continue
            raise ControllerConflict(
                f"{TWO_CONTROLLERS}: {who} on {topic_name} in this "
                "episode; the controller contract allows one decider (docs/ros.md): with "
                "your own controller, start actuator_node with builtin_policy false")

    def _exchange(self, episode_id: str, closing_displacement: float, timeout: float,
                  set_up_time: float, should_stop, publish_clock, times: list):
        """The controller of a lockstep episode's simulation: at a control step, publish
        /clock and the true measurement (from the episode thread, once the outbox has
        published the states before it) and wait for the ClosingDecision of that step
        (``timeout`` s); its ``close``.  ``times`` gets (s from the last control step's
        decision to this one's, s of this step's wait for its decision), wall clock.

        Until the controller's first decision of the episode, the wait is ``set_up_time``
        s longer: the first measurement also waits for the loop's per-episode set-up,
        which starts with the same commands as the simulation (the sensor node builds its
        sensor and waits up to its ``match_timeout`` for its subscribers; seen to take over
        5 s on a loaded 2-core machine)."""
        frame = self.frame_id
        topic_name = self.sub_decision.topic_name
        launch_topic = self.sub_launch_decision.topic_name
        answered_once = [False]
        last = [None]                        # monotonic time of the last decision heard
        with self._lock:
            self._loop_episode = episode_id
            self._deciders, self._decided, self._twice = {}, set(), None

        def exchange(sim) -> bool:
            self._check_deciders()
            t_step = time.monotonic()
            launched = sim.launched
            kind = "closing" if launched else "launch"
            step, sim_time = sim.mission_step, sim.time
            msg = conv.measurement_msg(truth_of(sim), step, sim_time, episode_id,
                                       closing_displacement, frame, launched=launched)
            with self._lock:
                self._awaiting = (episode_id, step, kind)
                self._answer = None
                self._answered.clear()

            def send():
                publish_clock(step, sim_time)
                self.pub_truth.publish(msg)

            # after the states before it, from this thread: no hand-over to the outbox
            # thread on the loop's critical path (docs/ros.md, what lockstep costs)
            self._outbox.drain()
            send()
            wait = timeout if answered_once[0] else timeout + set_up_time
            deadline = time.monotonic() + wait
            while not self._answered.wait(0.05):
                if should_stop():
                    raise EpisodeAborted()
                if time.monotonic() > deadline:
                    what, where = (("ClosingDecision", topic_name) if launched else
                                   ("LaunchDecision", launch_topic))
                    raise ControllerTimeout(
                        f"{CONTROLLER_TIMEOUT} within {wait:g} s: no {what} on "
                        f"{where} for step {step} (t = {sim_time:.3f} s; is sensor_node "
                        "running, and a controller: actuator_node's built-in policy or yours?)")
            self._check_deciders()
            answered_once[0] = True
            now = time.monotonic()
            if last[0] is not None:
                times.append((now - last[0], now - t_step))
            last[0] = now
            return bool(self._answer.close if launched else self._answer.launch)

        return exchange

    def _wait_for_controller(self, timeout: float, launch: bool = False) -> None:
        """Wait (``timeout`` s at most) until the decision topic has a publisher matched
        (and the launch decision's too, when the episode's launch waits)."""
        subs = [self.sub_decision] + ([self.sub_launch_decision] if launch else [])
        deadline = time.monotonic() + timeout
        while any(s.get_publisher_count() < 1 for s in subs) \
                and time.monotonic() < deadline and self.context.ok():
            time.sleep(0.01)

    def stopping(self) -> bool:
        """True once the node is closing or its context shut down (SIGINT, SIGTERM)."""
        return self._stop.is_set() or not self.context.ok()

    def close(self) -> None:
        self._stop.set()
        if self._worker is not None:
            self._worker.join(timeout=5.0)
        self._outbox.close()


def main(args=None) -> int:
    return run_node(SimNode, args, events=True)


if __name__ == "__main__":
    raise SystemExit(main())
