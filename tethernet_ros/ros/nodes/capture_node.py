"""Capture node: the RunCapture service, the Capture action, and the suite's bag recorder.

Service     RunCapture (``service`` parameter, default /tethernet/run_capture).
Action      Capture (``action`` parameter, default /tethernet/capture): the same capture as
            a goal, with feedback (sim time, CQI, n_L of the latest state) and cancel.
Service     std_srvs/Trigger /tethernet/suite_ready: success when this node sees every
            subscriber and publisher of the suite (its message says what is missing).
Publishes   EpisodeSetup (the validated request plus this node's SimConfig parameters), and
            the episode id on the cancel topic when a goal is canceled.
Subscribes  every suite topic, serialized (raw CDR), and writes it to the episode's bag.

One request or goal = one episode (one at a time; others wait their turn):
  1. validate the request (design, noise settings, bag name); an invalid one ends with
     status REJECTED and an error naming the field, and the node keeps serving;
  2. check that the simulation, monitor and actuator nodes are up (graph matching), and
     for a lockstep episode the sensor node and a controller; REJECTED if not;
  3. open the bag (``<bag_dir>/<name>.partial`` with an INCOMPLETE marker, bags/naming.py),
     publish the EpisodeSetup, and record everything until the simulation's EpisodeResult
     and the monitor's verdict have arrived and every stamped topic has reached the
     result's stamp (recording.py); a simulation that stops publishing states for
     ``stall_timeout`` s (or never starts within ``start_timeout`` s) ends the episode
     ABORTED with a one-line error, and the bag stays marked incomplete; so does a
     lockstep episode whose controller did not answer (the simulation's result says so,
     names.CONTROLLER_TIMEOUT); a canceled goal ends CANCELED (the simulation is told to
     stop, the bag stays marked incomplete);
  4. close the bag (metadata.yaml, rename to ``<bag_dir>/<name>``), check that the
     monitor's verdict equals the simulation's result exactly (ABORTED if not), and
     answer SUCCEEDED with the result and the bag path.
A shutdown (SIGINT, SIGTERM) during an episode ends it at once: the bag is finished as
far as it got and left ``.partial`` with the reason in its INCOMPLETE marker.
"""
from __future__ import annotations

import threading
import time
from pathlib import Path

import rclpy
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from ...bags import BagError, BagWriter, message_definition, qos_profile
from ...bags.naming import capture_name, check_name, taken
from ...core.config import ConfigError, SimConfig
from .. import conversions as conv
from ..loop import in_lockstep
from ..names import ABORTED, ALWAYS_RECORDED, CANCELED, LATCHED, LOCKSTEP_PUBLISHERS, \
    LOCKSTEP_SUBSCRIBERS, READY_SERVICE, REJECTED, REQUIRED_PUBLISHERS, REQUIRED_SUBSCRIBERS, \
    STATUS_NAMES, SUCCEEDED, TOPIC_TYPES, TOPICS, WATCHED, is_loop_failure, recorder_name
from ..parameters import declare, describe_builtin, param, sim_config_of, sim_config_problem, \
    topic
from ..qos import ALIVE_DEADLINE_S, LATCHED_DEPTH, alive_qos, command_qos, state_qos
from ..recording import Episode, msg_class
from ..results import compare_results
from ..runner import run_node, spin_while_ok

NODE = "capture_node"
#: depth of the recorder's subscriptions (and of the QoS the bag says they were offered)
STATE_DEPTH = 1000
#: topics recorded with the states' QoS (the rest: the commands' QoS)
STATE_TOPICS = ("net_state", "target_pose", "markers", "metrics", "clock", "true_measurement",
                "measurement", "closing_decision", "launch_decision", "sensed_target_pose",
                "sensed_target_twist", "sensed_net_point")
SHUTDOWN = "the capture node shut down during the episode (SIGINT or SIGTERM)"
CANCELED_TEXT = "canceled by the client"
#: s (wall) of quiet the bag of a lockstep episode whose loop failed waits for
LOOP_DRAIN_S = 0.25
#: s (wall) between two feedback messages of a goal
FEEDBACK_PERIOD = 0.1
#: s (wall) between two sendings of an episode's setup until the episode is seen running
#: (the setup handshake, docs/ros.md)
SETUP_RESEND_S = 1.0
#: threads of the node's executor: the service, a goal's execution, the action server's
#: requests (goal, cancel, result) and suite_ready can all be in a callback at once
THREADS = 4


class CaptureNode(Node):
    def __init__(self):
        from rclpy.action import ActionServer, CancelResponse, GoalResponse
        from std_msgs.msg import String
        from std_srvs.srv import Trigger
        from tethernet_msgs.action import Capture
        from tethernet_msgs.msg import EpisodeSetup
        from tethernet_msgs.srv import RunCapture

        super().__init__(NODE)
        declare(self, NODE, check=sim_config_problem)  # bad values stop the node, one line
        for type_name in TOPIC_TYPES.values():
            message_definition(type_name)   # every type is known to the bag writer (cached)
        self.episode: Episode | None = None
        self.topic_names = {k: topic(self, k) for k in TOPICS}
        self.pub_setup = self.create_publisher(EpisodeSetup, self.topic_names["setup"],
                                               command_qos())
        self.pub_cancel = self.create_publisher(String, self.topic_names["cancel"], command_qos())
        self._busy = threading.Lock()              # one episode at a time
        # The recorder is a second node spun by its own single-threaded executor in its
        # own thread: the service callback below blocks for a whole episode, and rclpy's
        # multi-threaded executor costs about three times more CPU per message (measured
        # 0.95 vs 0.33 ms; rclpy.experimental.EventsExecutor, 0.09 ms, hung in this role).
        # A name remap given to the process (``ros2 launch``'s ``name=``, ``-r __node:=``)
        # renames every node of the process; the recorder's own remap (local arguments
        # win over global ones) keeps it apart: <capture node's name>_recorder, in the
        # same namespace and with the same topic remaps.
        recorder = recorder_name(self.get_name())
        self.recorder = rclpy.create_node(recorder, context=self.context,
                                          cli_args=["--ros-args", "-r", f"__node:={recorder}"])
        describe_builtin(self.recorder)
        self.recorded = list(param(self, "record_topics"))
        for key in ALWAYS_RECORDED:               # replay needs them; the recorder counts them
            if key not in self.recorded:
                self.recorded.append(key)
        self._rec_subs = {}
        # the nodes' liveliness, from the recorder's subscriptions of the topics that show
        # it (names.WATCHED): live publishers per topic, and whether any ever was
        self._alive = {key: 0 for key in WATCHED}
        self._ever_alive = {key: False for key in WATCHED}
        for key in self.recorded:
            qos = state_qos(STATE_DEPTH) if key in STATE_TOPICS else command_qos()
            events = None
            if key in WATCHED:
                qos = alive_qos(qos, ALIVE_DEADLINE_S)
                events = SubscriptionEventCallbacks(
                    liveliness=lambda event, k=key: self.on_liveliness(k, event))
            self._rec_subs[key] = self.recorder.create_subscription(
                msg_class(TOPIC_TYPES[key]), self.topic_names[key],
                lambda data, k=key: self.on_raw(k, data), qos, raw=True, event_callbacks=events)
        self._rec_executor = SingleThreadedExecutor(context=self.context)
        self._rec_executor.add_node(self.recorder)
        self._rec_thread = threading.Thread(target=self._spin_recorder, name="recorder",
                                            daemon=True)
        self._rec_thread.start()
        # the service and a goal block for a whole episode (in their own callback groups,
        # on the executor's threads: main() runs THREADS); suite_ready, goal and cancel
        # requests are answered meanwhile
        self.create_service(RunCapture, param(self, "service"), self.on_request,
                            callback_group=MutuallyExclusiveCallbackGroup())
        self._capture = Capture
        self._action = ActionServer(
            self, Capture, param(self, "action"), execute_callback=self.on_goal,
            goal_callback=lambda goal: GoalResponse.ACCEPT,        # see Capture.action
            cancel_callback=lambda goal_handle: CancelResponse.ACCEPT,
            callback_group=ReentrantCallbackGroup())
        # readiness as this node sees the graph (DDS discovery reaches each participant at
        # its own pace: a launcher's view of the graph is not this node's)
        self.create_service(Trigger, READY_SERVICE, self.on_ready)
        self.get_logger().info(f"ready: service {param(self, 'service')}, action "
                               f"{param(self, 'action')}, bags in "
                               f"{Path(param(self, 'bag_dir')).resolve()}")

    def on_ready(self, request, response):
        missing = self.missing_nodes(0.0, lockstep=bool(param(self, "lockstep")))
        response.success = not missing
        response.message = missing or "ready"
        return response

    def _spin_recorder(self) -> None:
        try:
            spin_while_ok(self._rec_executor, self.context)
        except Exception:  # noqa: BLE001 - shutdown
            pass

    # -- configuration ---------------------------------------------------------------------
    def sim_config(self) -> SimConfig:
        """The episodes' SimConfig (parameters sim_config, settle_time, horizon)."""
        return sim_config_of({k: param(self, k) for k in ("sim_config", "settle_time", "horizon")})

    # -- recorder --------------------------------------------------------------------------
    def on_liveliness(self, key: str, event) -> None:
        """A watched topic's publishers came alive or were lost (names.WATCHED)."""
        self._alive[key] = int(event.alive_count)
        if event.alive_count > 0:
            self._ever_alive[key] = True

    def gone_nodes(self, lockstep: bool) -> list[str]:
        """The suite's nodes that were alive and are no longer (their process died or
        shut down), by the liveliness of the topics that show them (names.WATCHED): the
        sensor node counts in lockstep episodes only."""
        gone = []
        for key, node in WATCHED.items():
            if key == "measurement" and not lockstep:
                continue
            if self._ever_alive[key] and self._alive[key] < 1:
                gone.append(f"{node} (no live publisher on {self.topic_names[key]} for "
                            f"{ALIVE_DEADLINE_S:g} s)")
        return gone

    def on_raw(self, key: str, data: bytes) -> None:
        ep = self.episode
        if ep is not None:
            ep.record(key, self.topic_names[key], data)

    def open_bag(self, bag_dir: Path, episode_id: str, design, seed) -> BagWriter:
        writer = BagWriter(bag_dir / episode_id, compression=param(self, "compression"),
                           custom_data={"tethernet.episode_id": episode_id,
                                        "tethernet.design": str(design.to_dict()),
                                        "tethernet.seed": "nominal" if seed is None else str(seed)})
        for key in self.recorded:
            depth = STATE_DEPTH if key in STATE_TOPICS else 10
            writer.add_topic(self.topic_names[key], TOPIC_TYPES[key],
                             qos_profile(LATCHED_DEPTH if key in LATCHED else depth,
                                         latched=key in LATCHED))
        return writer

    # -- service ---------------------------------------------------------------------------
    def check_request(self, request, bag_dir: Path):
        """(design, noise model or None) of a request; RequestError names a bad field."""
        design = conv.design_from_msg(request.design)
        noise = None if request.nominal else conv.noise_model_from_msg(request.noise)
        if getattr(request, "set_tumble", False):
            conv.tumble_from_msg(request.tumble)
        conv.target_from_request(request)
        conv.launch_from_request(request)
        name = request.bag_name
        if name:
            try:
                check_name(name)
            except BagError as exc:
                raise conv.RequestError("bag_name", str(exc)) from None
            where = taken(bag_dir, name) if request.record_bag else None
            if where is not None:
                raise conv.RequestError("bag_name", f"a bag {str(where)!r} already exists")
        return design, noise

    def on_request(self, request, response):
        return conv.capture_reply(response, self.capture(request))

    def on_goal(self, goal_handle):
        t0 = time.monotonic()

        def feedback(metrics, states):
            goal_handle.publish_feedback(conv.capture_feedback_msg(metrics, states,
                                                                   time.monotonic() - t0))

        outcome = self.capture(goal_handle.request, feedback=feedback,
                               canceled=lambda: goal_handle.is_cancel_requested)
        if outcome.status == SUCCEEDED:
            goal_handle.succeed()
        elif outcome.status == CANCELED:
            goal_handle.canceled()
        else:
            goal_handle.abort()
        return conv.capture_reply(self._capture.Result(), outcome)

    def capture(self, request, feedback=None, canceled=None) -> conv.Outcome:
        """One episode of a RunCapture request or Capture goal (the same fields), after
        the episode before it.  feedback(metrics message or None, states heard): called
        every FEEDBACK_PERIOD s while it runs; canceled(): True once the client canceled."""
        canceled = canceled or (lambda: False)
        while not self._busy.acquire(timeout=0.05):
            if not self.context.ok():
                return conv.Outcome(ABORTED, SHUTDOWN)
            if canceled():
                return conv.Outcome(CANCELED, f"{CANCELED_TEXT} (before the episode started)")
        try:
            outcome = self._capture_episode(request, feedback, canceled)
        finally:
            self._busy.release()
        log = self.get_logger()
        text = f"{STATUS_NAMES[outcome.status].lower()}: {outcome.error}"
        if outcome.status == REJECTED:
            log.warning(text)
        elif outcome.status == ABORTED:
            log.error(text)
        elif outcome.status == CANCELED:
            log.info(outcome.error)
        return outcome

    def _capture_episode(self, request, feedback, canceled) -> conv.Outcome:
        log = self.get_logger()
        bag_dir = Path(param(self, "bag_dir"))
        try:
            design, noise = self.check_request(request, bag_dir)
        except conv.RequestError as exc:
            return conv.Outcome(REJECTED, str(exc))
        try:
            config = conv.config_with_tumble(self.sim_config(), request)
            conv.check_pull(design, config)
        except conv.RequestError as exc:
            return conv.Outcome(REJECTED, str(exc))
        except (ConfigError, ValueError) as exc:
            return conv.Outcome(REJECTED, f"capture node configuration: {exc}")
        lockstep = bool(param(self, "lockstep"))
        missing = self.missing_nodes(float(param(self, "ready_timeout")),
                                     lockstep=in_lockstep(lockstep, config))
        if missing:
            return conv.Outcome(REJECTED, f"suite not ready: {missing}")
        seed = None if request.nominal else int(request.seed)
        episode_id = request.bag_name or capture_name(seed)
        writer = None
        if request.record_bag:
            try:
                writer = self.open_bag(bag_dir, episode_id, design, seed)
            except (BagError, OSError) as exc:
                return conv.Outcome(REJECTED, f"bag_name: cannot record the bag: {exc}")
        ep = Episode(episode_id=episode_id, writer=writer, started=time.monotonic())
        self.episode = ep
        log.info(f"episode {episode_id!r}: {'nominal' if seed is None else f'seed {seed}'}")
        try:
            setup = conv.setup_msg(episode_id, design, int(request.seed), noise, config,
                                   time.time(), nominal=request.nominal, lockstep=lockstep)
            self.pub_setup.publish(setup)
            error = self.wait_for_end(ep, feedback, canceled,
                                      lockstep=in_lockstep(lockstep, config), setup=setup)
        except Exception as exc:  # noqa: BLE001 - reported in the answer
            error = f"{type(exc).__name__}: {exc}"
        except BaseException:                    # KeyboardInterrupt: leave a marked bag
            if writer is not None:
                writer.abort(SHUTDOWN)
            raise
        finally:
            self.episode = None
        if error:
            status = CANCELED if error == CANCELED_TEXT else ABORTED
            if self.context.ok():     # the simulation stops an episode given up (if it runs)
                self.pub_cancel.publish(conv.cancel_msg(episode_id))
            bag = str(writer.abort(error).resolve()) if writer is not None else ""
            return conv.Outcome(status, error, bag_path=bag)
        bag = str(writer.close().resolve()) if writer is not None else ""
        mismatch = compare_results(ep.result, ep.verdict)
        if mismatch:
            return conv.Outcome(ABORTED, f"monitor verdict disagrees with the simulation: "
                                f"{mismatch}", bag_path=bag)
        return conv.Outcome(SUCCEEDED, result=ep.result, bag_path=bag)

    def wait_for_end(self, ep: Episode, feedback=None, canceled=None, lockstep: bool = False,
                     setup=None) -> str:
        """'' once the result and the verdict are in (and late messages drained), else
        the reason the episode failed (a node of the suite gone, a timeout, the node
        shutting down, CANCELED_TEXT).  A node whose process is gone is noticed within
        qos.ALIVE_DEADLINE_S by its liveliness; the stall timeout is the last resort for
        a node that lives but hangs.  ``setup`` (the EpisodeSetup sent) is sent again
        every SETUP_RESEND_S until the episode is seen running (the setup handshake,
        docs/ros.md)."""
        start_to = float(param(self, "start_timeout"))
        stall_to = float(param(self, "stall_timeout"))
        total_to = float(param(self, "episode_timeout"))
        sim = self.topic_names["net_state"]
        next_feedback, fed = 0.0, -1
        next_setup = time.monotonic() + SETUP_RESEND_S
        while not ep.ended.wait(0.05):
            if not self.context.ok():
                return SHUTDOWN
            if canceled is not None and canceled():
                return CANCELED_TEXT
            gone = self.gone_nodes(lockstep)
            if gone:
                return (f"{'; '.join(gone)}: the node left the suite during the episode (its "
                        "process died or shut down)")
            now = time.monotonic()
            if setup is not None and now >= next_setup:
                if ep.seen_running():
                    setup = None
                else:               # a reader that matched late missed it: the same again
                    self.pub_setup.publish(setup)
                    next_setup = now + SETUP_RESEND_S
            if feedback is not None and now >= next_feedback:
                n, data = ep.progress()
                if n != fed:
                    fed, next_feedback = n, now + FEEDBACK_PERIOD
                    feedback(None if data is None else conv.metrics_from_cdr(data), ep.n_states)
            if ep.last_state is None and now - ep.started > start_to:
                return (f"timed out: no state on {sim} within {start_to:g} s of the request "
                        "(is sim_node running?)")
            if ep.last_state is not None and now - ep.last_state > stall_to:
                if ep.result is not None:
                    return (f"timed out: the monitor gave no verdict within {stall_to:g} s of the "
                            "last state (is monitor_node running?)")
                return (f"timed out: the simulation stopped publishing states on {sim} for "
                        f"{stall_to:g} s after {ep.n_states} states (sim_node died or hung)")
            if now - ep.started > total_to:
                return f"timed out: the episode took longer than episode_timeout = {total_to:g} s"
        if ep.result is not None and is_loop_failure(ep.result.failure_reason):
            # a lockstep episode's loop failed: the messages on their way (a second
            # decider's decisions) still reach the bag, for `tethernet replay` to show
            deadline = time.monotonic() + 2.0
            while ep.quiet_for() < LOOP_DRAIN_S and time.monotonic() < deadline \
                    and self.context.ok():
                time.sleep(0.01)
            return ep.result.failure_reason
        # the last state's markers, pose, clock and metrics may still be on their way
        drain = float(param(self, "drain_time"))
        limit = max(10 * drain, 2.0)
        deadline = time.monotonic() + limit
        while True:
            behind = ep.behind()
            if not behind and ep.settled() and ep.quiet_for() >= drain:
                break
            if not self.context.ok():
                return SHUTDOWN
            if time.monotonic() > deadline:
                st = ep.result.header.stamp
                self.get_logger().warning(
                    f"episode {ep.episode_id!r}: {', '.join(behind) or 'metrics'} did not reach "
                    f"the final state (t = {st.sec + 1e-9 * st.nanosec:.3f} s) within {limit:g} s; "
                    "the bag holds what arrived")
                break
            time.sleep(0.002)
        if feedback is not None:
            n, data = ep.progress()
            feedback(None if data is None else conv.metrics_from_cdr(data), ep.n_states)
        return ""

    def missing_nodes(self, timeout: float, lockstep: bool = False) -> str:
        """'' when every topic of the suite has its subscribers and publishers (with
        ``lockstep``, also the loop's: the sensor node and a controller), else what is
        missing (after waiting up to ``timeout`` s)."""
        deadline = time.monotonic() + timeout
        subscribers = dict(REQUIRED_SUBSCRIBERS)
        publishers = list(REQUIRED_PUBLISHERS)
        if lockstep:
            subscribers.update(LOCKSTEP_SUBSCRIBERS)
            publishers += LOCKSTEP_PUBLISHERS
        while True:
            missing = []
            for key, n in subscribers.items():
                have = (self.pub_setup.get_subscription_count() if key == "setup"
                        else self.count_subscribers(self.topic_names[key]))
                if have < n:
                    missing.append(f"{self.topic_names[key]} has {have} of {n} subscribers")
            for key in publishers:
                if self.count_publishers(self.topic_names[key]) < 1:
                    missing.append(f"no publisher on {self.topic_names[key]}")
            # a node whose process is gone may stay in the graph for DDS's lease (~20 s)
            missing += [f"{g}: not alive" for g in self.gone_nodes(lockstep)]
            # the recorder (a node of this process) must have matched this node's setup
            # publisher, or a bag could miss the episode's first message (seen under load)
            if self._rec_subs["setup"].get_publisher_count() < 1:
                missing.append(f"the recorder has not matched {self.topic_names['setup']}")
            if not missing:
                return ""
            if time.monotonic() > deadline or not self.context.ok():
                return "; ".join(missing) + (" (start sim_node, monitor_node, actuator_node"
                                             + (", sensor_node and a controller (actuator_node"
                                                " with builtin_policy, or yours))"
                                                if lockstep else ")"))
            time.sleep(0.05)

    def close(self) -> None:
        # an episode in flight sees the context gone within 0.05 s and finishes its bag
        # (marked with the reason) under the lock: let it, before the process ends
        # (runner.exit_process ends the other threads with it)
        if self._busy.acquire(timeout=3.0):
            self._busy.release()
        ep = self.episode
        if ep is not None and ep.writer is not None:
            ep.writer.abort(SHUTDOWN)
        try:
            self._rec_executor.shutdown(timeout_sec=1.0)
        except Exception:  # noqa: BLE001
            pass
        # the recorder thread must have left rcl before anything of the node is destroyed
        # (the action server destroyed while it waited crashed the process, 2 of 32 runs
        # under ros2 launch) and before the process exits
        self._rec_thread.join(timeout=2.0)
        self._action.destroy()
        self.recorder.destroy_node()


def main(args=None) -> int:
    return run_node(CaptureNode, args, threads=THREADS)


if __name__ == "__main__":
    raise SystemExit(main())
