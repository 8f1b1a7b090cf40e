"""Capture service node: the RunCapture service, and the suite's bag recorder.

Service     RunCapture (``service`` parameter, default /tethernet/run_capture).
Service     std_srvs/Trigger /tethernet/suite_ready: success when this node sees every
            subscriber and publisher of the suite (its message says what is missing).
Publishes   EpisodeSetup (the validated request plus this node's SimConfig parameters).
Subscribes  every suite topic, serialized (raw CDR), and writes it to the episode's bag.

One request = one episode:
  1. validate the request (design, noise settings, bag name); an invalid one gets
     ``accepted = false`` and an error naming the field, and the node keeps serving;
  2. check that the simulation, monitor and actuator nodes are up (graph matching);
  3. open the bag (``<bag_dir>/<name>.partial`` with an INCOMPLETE marker), publish the
     EpisodeSetup, and record everything until the simulation's EpisodeResult and the
     monitor's verdict have arrived; a simulation that stops publishing states for
     ``stall_timeout`` s (or never starts within ``start_timeout`` s) aborts the episode
     with a one-line error, and the bag stays marked incomplete;
     The recording is complete when every stamped topic heard during the episode (states,
     metrics, markers, pose, clock) has reached the stamp of the simulation's result,
     which is its last state's: no topic waits on a timer;
  4. close the bag (metadata.yaml, rename to ``<bag_dir>/<name>``), check that the
     monitor's verdict equals the simulation's result exactly, and respond with the
     result and the bag path.
"""
from __future__ import annotations

import importlib
import re
import secrets
import struct
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.serialization import deserialize_message

from ..bags import BagError, BagWriter, message_definition, qos_profile
from ..core.config import ConfigError, SimConfig
from . import common, convert

NODE = "capture_node"
BAG_NAME = re.compile(r"[A-Za-z0-9_\-][A-Za-z0-9_.\-]{0,199}")


#: recorded topics whose messages carry the simulated time of a state (header stamp)
STAMPED = ("net_state", "metrics", "markers", "target_pose", "clock")


def cdr_stamp(key: str, data: bytes) -> tuple[int, int] | None:
    """(sec, nanosec) stamp of a serialized (CDR) message of a STAMPED topic, read in
    place: the header (or, for /clock, the time) is the first field; a MarkerArray's is
    its first marker's (None when it has none)."""
    order = "<" if data[1] == 1 else ">"         # encapsulation id: CDR_LE 0x0001, CDR_BE 0x0000
    offset = 4
    if key == "markers":
        (count,) = struct.unpack_from(order + "I", data, offset)
        if count == 0:
            return None
        offset += 4
    sec, nsec = struct.unpack_from(order + "iI", data, offset)
    return sec, nsec


def msg_class(type_name: str):
    pkg, _, name = type_name.split("/")
    return getattr(importlib.import_module(f"{pkg}.msg"), name)


@dataclass
class Episode:
    episode_id: str
    writer: BagWriter | None
    started: float
    last_state: float | None = None
    n_states: int = 0
    n_metrics: int = 0
    last_message: float = 0.0
    result: object = None
    verdict: object = None
    last_stamp: dict = field(default_factory=dict)   # STAMPED key -> (sec, nanosec)
    event: threading.Event = field(default_factory=threading.Event)


class CaptureNode(Node):
    def __init__(self):
        from tethernet_msgs.msg import EpisodeSetup
        from std_srvs.srv import Trigger
        from tethernet_msgs.srv import RunCapture

        super().__init__(NODE)
        common.declare(self, NODE)
        self.sim_config()  # a bad configuration stops the node at start, with one line
        for type_name in common.TOPIC_TYPES.values():
            message_definition(type_name)   # every .msg file is there (and cached)
        self._lock = threading.Lock()
        self.episode: Episode | None = None
        self.topic_names = {k: common.topic(self, k) for k in common.TOPICS}
        depth = 1000
        self.pub_setup = self.create_publisher(EpisodeSetup, self.topic_names["setup"],
                                               common.command_qos())
        # The recorder is a second node spun by its own single-threaded executor in its
        # own thread: the service callback below blocks for a whole episode, and rclpy's
        # multi-threaded executor costs about three times more CPU per message (measured
        # 0.95 vs 0.33 ms; rclpy.experimental.EventsExecutor, 0.09 ms, hung in this role).
        self.recorder = rclpy.create_node(NODE + "_recorder", context=self.context)
        self.qos_offered = {}
        self.recorded = list(common.param(self, "record_topics"))
        unknown = [k for k in self.recorded if k not in common.TOPIC_TYPES]
        if unknown:
            raise ValueError(f"parameter 'record_topics': unknown {unknown}; allowed "
                             f"{list(common.TOPIC_TYPES)}")
        for key in common.ALWAYS_RECORDED:        # replay needs them; the recorder counts them
            if key not in self.recorded:
                self.recorded.append(key)
        for key in self.recorded:
            type_name = common.TOPIC_TYPES[key]
            big = key in ("net_state", "target_pose", "markers", "metrics", "clock")
            qos = common.state_qos(depth) if big else common.command_qos()
            self.qos_offered[key] = qos_profile(depth if big else 10)
            self.recorder.create_subscription(msg_class(type_name), self.topic_names[key],
                                              lambda data, k=key: self.on_raw(k, data), qos,
                                              raw=True)
        self._rec_executor = SingleThreadedExecutor(context=self.context)
        self._rec_executor.add_node(self.recorder)
        self._rec_thread = threading.Thread(target=self._spin_recorder, name="recorder",
                                            daemon=True)
        self._rec_thread.start()
        self.create_service(RunCapture, common.param(self, "service"), self.on_request)
        # readiness as this node sees the graph (DDS discovery reaches each participant at
        # its own pace: a launcher's view of the graph is not this node's)
        self.create_service(Trigger, common.READY_SERVICE, self.on_ready)
        self.get_logger().info(f"ready: service {common.param(self, 'service')}, bags in "
                               f"{Path(common.param(self, 'bag_dir')).resolve()}")

    def on_ready(self, request, response):
        missing = self.missing_nodes(0.0)
        response.success = not missing
        response.message = missing or "ready"
        return response

    def _spin_recorder(self) -> None:
        try:
            self._rec_executor.spin()
        except Exception:  # noqa: BLE001 - shutdown
            pass

    # -- configuration ---------------------------------------------------------------------
    def sim_config(self) -> SimConfig:
        import json

        text = common.param(self, "sim_config") or "{}"
        try:
            data = json.loads(text)
        except ValueError:
            raise ConfigError(f"parameter 'sim_config': not a JSON object: {text!r}") from None
        if not isinstance(data, dict):
            raise ConfigError("parameter 'sim_config': must be a JSON object of SimConfig fields")
        data["settle_time"] = float(common.param(self, "settle_time"))
        data["horizon"] = float(common.param(self, "horizon"))
        return SimConfig.from_dict(data)

    # -- recorder --------------------------------------------------------------------------
    def on_raw(self, key: str, data: bytes) -> None:
        ep = self.episode
        if ep is None:
            return
        now_ns = time.time_ns()
        if ep.writer is not None:
            ep.writer.write(self.topic_names[key], data, now_ns)
        now = time.monotonic()
        with self._lock:
            ep.last_message = now
            if key in STAMPED:
                st = cdr_stamp(key, data)
                if st is not None:
                    ep.last_stamp[key] = st
            if key == "net_state":
                ep.n_states += 1
                ep.last_state = now
            elif key == "metrics":
                ep.n_metrics += 1
            elif key in ("result", "verdict"):
                from tethernet_msgs.msg import EpisodeResult

                msg = deserialize_message(data, EpisodeResult)
                if msg.episode_id == ep.episode_id:
                    setattr(ep, key, msg)
                    if ep.result is not None and ep.verdict is not None:
                        ep.event.set()

    # -- service ---------------------------------------------------------------------------
    def on_request(self, request, response):
        log = self.get_logger()
        response.accepted = False
        try:
            design = convert.design_from_msg(request.design)
            noise = None if request.nominal else convert.noise_model_from_msg(request.noise)
            name = request.bag_name
            if name and not BAG_NAME.fullmatch(name):
                raise convert.RequestError("bag_name", f"got {name!r}; use up to 200 letters, "
                                           "digits, '_', '-' or '.', not starting with '.'")
            bag_dir = Path(common.param(self, "bag_dir"))
            if name and request.record_bag and ((bag_dir / name).exists()
                                                or (bag_dir / (name + ".partial")).exists()):
                raise convert.RequestError("bag_name", f"a bag {str(bag_dir / name)!r} already exists")
        except convert.RequestError as exc:
            response.error = str(exc)
            log.warning(f"request rejected: {exc}")
            return response
        try:
            config = self.sim_config()
        except (ConfigError, ValueError) as exc:
            response.error = f"capture node configuration: {exc}"
            return response
        missing = self.missing_nodes(float(common.param(self, "ready_timeout")))
        if missing:
            response.error = f"suite not ready: {missing}"
            log.error(response.error)
            return response
        seed = None if request.nominal else int(request.seed)
        episode_id = name or time.strftime("capture_%Y%m%d-%H%M%S_") + \
            ("nominal" if seed is None else f"seed{seed}") + "_" + secrets.token_hex(2)
        writer = None
        if request.record_bag:
            try:
                writer = BagWriter(bag_dir / episode_id, compression=common.param(self, "compression"),
                                   custom_data={"tethernet.episode_id": episode_id,
                                                "tethernet.design": str(design.to_dict()),
                                                "tethernet.seed": "nominal" if seed is None else str(seed)})
                for key in self.recorded:
                    writer.add_topic(self.topic_names[key], common.TOPIC_TYPES[key],
                                     self.qos_offered[key])
            except (BagError, OSError) as exc:
                response.error = f"bag_name: cannot record the bag: {exc}"
                return response
        response.accepted = True
        ep = Episode(episode_id=episode_id, writer=writer, started=time.monotonic())
        self.episode = ep
        log.info(f"episode {episode_id!r}: {'nominal' if seed is None else f'seed {seed}'}")
        try:
            self.pub_setup.publish(convert.setup_msg(episode_id, design, seed, noise, config,
                                                     time.time()))
            error = self.wait_for_end(ep)
        except Exception as exc:  # noqa: BLE001 - reported in the response
            error = f"{type(exc).__name__}: {exc}"
        finally:
            self.episode = None
        if error:
            response.error = error
            if writer is not None:
                response.bag_path = str(writer.abort(error).resolve())
            log.error(f"episode {episode_id!r}: {error}")
            return response
        if writer is not None:
            response.bag_path = str(writer.close().resolve())
        response.result = ep.result
        mismatch = convert.compare_results(ep.result, ep.verdict)
        if mismatch:
            response.error = f"monitor verdict disagrees with the simulation: {mismatch}"
            log.error(response.error)
        return response

    def wait_for_end(self, ep: Episode) -> str:
        """'' once the result and the verdict are in (and late messages drained), else
        the reason the episode failed."""
        start_to = float(common.param(self, "start_timeout"))
        stall_to = float(common.param(self, "stall_timeout"))
        total_to = float(common.param(self, "episode_timeout"))
        sim = self.topic_names["net_state"]
        while not ep.event.wait(0.05):
            now = time.monotonic()
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
        # the last state's markers, pose, clock and metrics may still be on their way: wait
        # until every stamped topic heard in this episode has reached the result's stamp
        final = (ep.result.header.stamp.sec, ep.result.header.stamp.nanosec)
        drain = float(common.param(self, "drain_time"))
        deadline = time.monotonic() + max(10 * drain, 2.0)
        while True:
            with self._lock:
                behind = sorted(k for k, st in ep.last_stamp.items() if st < final)
                behind += [k for k in ("net_state", "metrics") if k not in ep.last_stamp]
                quiet = time.monotonic() - ep.last_message >= drain
                settled = ep.n_metrics >= ep.n_states
            if not behind and settled and quiet:
                break
            if time.monotonic() > deadline:
                self.get_logger().warning(
                    f"episode {ep.episode_id!r}: {', '.join(behind) or 'metrics'} did not reach "
                    f"the final state (t = {final[0] + 1e-9 * final[1]:.3f} s) within "
                    f"{max(10 * drain, 2.0):g} s; the bag holds what arrived")
                break
            time.sleep(0.002)
        return ""

    def missing_nodes(self, timeout: float) -> str:
        """'' when every topic of the suite has its subscribers and publishers, else what
        is missing (after waiting up to ``timeout`` s)."""
        deadline = time.monotonic() + timeout
        while True:
            missing = []
            for key, n in common.REQUIRED_SUBSCRIBERS.items():
                have = (self.pub_setup.get_subscription_count() if key == "setup"
                        else self.count_subscribers(self.topic_names[key]))
                if have < n:
                    missing.append(f"{self.topic_names[key]} has {have} of {n} subscribers")
            for key in common.REQUIRED_PUBLISHERS:
                if self.count_publishers(self.topic_names[key]) < 1:
                    missing.append(f"no publisher on {self.topic_names[key]}")
            if not missing:
                return ""
            if time.monotonic() > deadline:
                return "; ".join(missing) + " (start sim_node, monitor_node and actuator_node)"
            time.sleep(0.05)

    def close(self) -> None:
        ep = self.episode
        if ep is not None and ep.writer is not None:
            ep.writer.abort("the capture node shut down during the episode")
        try:
            self._rec_executor.shutdown(timeout_sec=1.0)
        except Exception:  # noqa: BLE001
            pass
        self.recorder.destroy_node()


def main(args=None) -> int:
    return common.run_node(CaptureNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
