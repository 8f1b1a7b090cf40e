"""Run captures through the ROS 2 node suite, with the nodes as separate processes.

:class:`RosSuite` starts ``sim_node``, ``monitor_node``, ``actuator_node``, ``sensor_node``
and ``capture_node`` (``python -m tethernet_ros.ros.nodes.<name>``), and a user's
controller if asked (``controller``: a console script, or ``module:Class`` of a Node run
by :mod:`.controller_host`; the actuator's built-in policy is then off and every episode
runs in lockstep), talks to the RunCapture service from a client node in this process, and
stops the nodes (SIGINT, then SIGTERM, then SIGKILL).  :func:`capture_via_ros` is one
capture on a fresh suite; it is what ``tethernet capture --via ros`` calls.

Processes get ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST unless the environment sets it, and
the suite's ``domain_id``, else ROS_DOMAIN_ID from the environment, or else a private
domain derived from this process id so that simultaneous runs do not hear each other
(suites side by side take domains of their own: backend.py).  Node output goes to log
files in ``log_dir`` (a temporary folder unless given); errors quote the last lines.
"""
from __future__ import annotations

import hashlib
import math
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import warnings
from pathlib import Path

from ..core.config import SimConfig
from ..core.design import Design
from ..core.episode import EpisodeResult, EpisodeTrace
from ..core.noise import NoiseModel
from ..errors import UserError
from . import conversions as conv
from .loop import in_lockstep
from .names import LOCKSTEP_PUBLISHERS, LOCKSTEP_SUBSCRIBERS, NODES, READY_SERVICE, REJECTED, \
    REQUIRED_PUBLISHERS, REQUIRED_SUBSCRIBERS, SERVICE, STATUS_NAMES, SUCCEEDED, TOPICS

#: the process name (and log file) of a user's controller
CONTROLLER = "controller"

PACKAGE_ROOT = Path(__file__).resolve().parents[2]


#: s (wall) a started suite waits, once every node's writers have matched, for the
#: readers' side of the matching (RosSuite.start)
READER_GRACE_S = 1.0


class RosCaptureError(UserError):
    """A capture through the suite failed (a node died, timed out or refused); one line."""


def default_params_file() -> Path | None:
    """config/tethernet.yaml of the source tree, or of the installed share/ folder."""
    candidates = [PACKAGE_ROOT / "config" / "tethernet.yaml",
                  Path(sys.prefix) / "share" / "tethernet_ros" / "config" / "tethernet.yaml"]
    for p in candidates:
        if p.is_file():
            return p
    return None


def default_domain() -> int:
    """ROS_DOMAIN_ID of the environment, or else one of this process's own (1..100)."""
    value = os.environ.get("ROS_DOMAIN_ID", "")
    return int(value) if value.strip().isdigit() else 1 + os.getpid() % 100


def suite_environment(env: dict | None = None, domain_id: int | None = None) -> dict:
    env = dict(os.environ if env is None else env)
    env.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    if domain_id is not None:
        env["ROS_DOMAIN_ID"] = str(int(domain_id))
    env.setdefault("ROS_DOMAIN_ID", str(default_domain()))
    env.setdefault("PYTHONUNBUFFERED", "1")
    env.setdefault("RCUTILS_COLORIZED_OUTPUT", "0")
    return env


def node_parameters(config: SimConfig, noise_model: NoiseModel | None, bag_dir: str | Path,
                    extra: dict | None = None, lockstep: bool = False,
                    controller: str | None = None) -> dict:
    """ROS parameters (per node) that carry a SimConfig and a noise model's spreads;
    ``lockstep``: the closing policy through ROS; ``controller``: a user's node decides
    (the actuator's built-in policy off, lockstep)."""
    import json

    rest = {k: v for k, v in conv.config_overrides(config).items()
            if k not in ("settle_time", "horizon")}
    params = {
        "capture_node": {"settle_time": float(config.settle_time), "horizon": float(config.horizon),
                         "sim_config": json.dumps(rest, sort_keys=True),
                         "bag_dir": str(bag_dir)},
        "actuator_node": {},
        "sim_node": {},
        "monitor_node": {},
        "sensor_node": {},
    }
    if lockstep or controller:
        params["capture_node"]["lockstep"] = True
    if controller:
        params["actuator_node"]["builtin_policy"] = False
    if noise_model is not None:
        params["actuator_node"].update(
            {f"noise.{k}": float(v) for k, v in noise_model.spreads().items()})
    for node, values in (extra or {}).items():
        params.setdefault(node, {}).update(values)
    return params


def _is_module_spec(spec: str) -> bool:
    """Whether a controller spec is ``module:Class`` (else an executable's name or path)."""
    return ":" in spec and os.path.sep not in spec


def controller_command(spec: str) -> list[str]:
    """The command line of a user's controller: ``module:Class`` (a Node class, run by
    controller_host) or the name or path of an executable (a console script: this
    environment's bin/ first, then PATH).  Raises RosCaptureError if there is none."""
    if _is_module_spec(spec):
        return [sys.executable, "-m", "tethernet_ros.ros.controller_host", spec]
    path = shutil.which(spec, path=os.pathsep.join([str(Path(sys.executable).parent),
                                                    os.environ.get("PATH", "")]))
    if path is None:
        raise RosCaptureError(f"controller {spec!r}: no such executable (a console script, "
                              "a path, or module:Class of a Node)")
    return [path]


def controller_identity(spec: str) -> str:
    """What identifies a user's controller in a run key: its spec and the SHA-256 (16 hex
    digits) of its source, so that editing the controller starts new samples.  Source:
    for ``module:Class``, the module's file, looked up as the controller host will import
    it (``python -m``: the working directory, then ``PYTHONPATH``, then this process's
    path); for an executable, its own file (a console script's entry module is not
    followed: edit such a controller and its samples keep their key).  The spec alone, with
    a warning, if no file is found."""
    if _is_module_spec(spec):
        module = spec.split(":", 1)[0]
        rel = Path(*module.split("."))
        roots = ([os.getcwd()] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep)
                                  if p] + sys.path)
        files = (Path(root or ".") / r for root in roots
                 for r in (rel.with_suffix(".py"), rel / "__init__.py"))
        source = next((f for f in files if f.is_file()), None)
    else:
        try:
            source = Path(controller_command(spec)[0])
        except RosCaptureError:
            source = None
    if source is None:
        warnings.warn(f"controller {spec!r}: no source file found to identify it by; its "
                      "samples are keyed by its name alone", stacklevel=2)
        return spec
    return f"{spec} sha256:{hashlib.sha256(source.read_bytes()).hexdigest()[:16]}"


def _signal_text(code: int) -> str:
    if code < 0:
        try:
            return f"killed by signal {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit status {code}"


class RosSuite:
    """The suite's nodes as processes plus a client in this process.

    config: SimConfig of the episodes (carried by capture_node parameters); noise_model:
    its spreads become actuator_node parameters (scales travel with each request);
    params: extra parameters per node, e.g. ``{"sim_node": {"publish_rate": 50.0}}``;
    lockstep: run the closing policy through ROS (sensor_node, actuator_node) every control
    period; controller: a user's controller replaces the actuator's built-in policy
    (:func:`controller_command`; implies lockstep); domain_id: the suite's ROS domain.
    """

    def __init__(self, config: SimConfig | None = None, noise_model: NoiseModel | None = None,
                 params: dict | None = None, bag_dir: str | Path = "bags",
                 log_dir: str | Path | None = None, env: dict | None = None,
                 lockstep: bool = False, controller: str | None = None,
                 domain_id: int | None = None):
        self.config = config or SimConfig()
        self.controller = controller
        self.lockstep = in_lockstep(lockstep or controller, self.config)
        self.noise_model = noise_model
        self.bag_dir = Path(bag_dir)
        self._tmp = None
        if log_dir is None:
            self._tmp = tempfile.TemporaryDirectory(prefix="tethernet_ros_")
            log_dir = self._tmp.name
        self.log_dir = Path(log_dir)
        self.log_dir.mkdir(parents=True, exist_ok=True)
        self.params = node_parameters(self.config, noise_model, self.bag_dir, params,
                                      lockstep=lockstep, controller=controller)
        self.env = suite_environment(env, domain_id)
        self.procs: dict[str, subprocess.Popen] = {}
        self._logs = {}
        self._context = None
        self._node = None
        self._client = None
        self._metrics: list = []
        self._executor = None
        #: a cancelled call left its episode running in the nodes (RosSuite.call)
        self._abandoned = False

    # -- processes -----------------------------------------------------------------------
    def _write_params(self) -> Path:
        import yaml

        path = self.log_dir / "params.yaml"
        doc = {f"/{node}": {"ros__parameters": values} for node, values in self.params.items()
               if values}
        path.write_text(yaml.safe_dump(doc, sort_keys=True))
        return path

    def start(self, timeout: float = 300.0) -> RosSuite:
        """Start the nodes and wait until the service is up and every node has joined
        the graph (the simulation node joins after loading its numba kernels, which can
        take minutes when they must be compiled)."""
        self._abandoned = False
        overrides = self._write_params()
        defaults = default_params_file()
        for name in NODES:
            # as `ros2 launch` starts them (launch/tethernet.launch.py: Node(name=...)):
            # the node name as a remap of the whole process
            cmd = [sys.executable, "-m", f"tethernet_ros.ros.nodes.{name}", "--ros-args",
                   "-r", f"__node:={name}"]
            if defaults is not None:
                cmd += ["--params-file", str(defaults)]
            cmd += ["--params-file", str(overrides)]
            log = open(self.log_dir / f"{name}.log", "wb")
            self._logs[name] = log
            self.procs[name] = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT,
                                                stdin=subprocess.DEVNULL, env=self.env,
                                                start_new_session=True)
        if self.controller:
            try:
                cmd = controller_command(self.controller)
            except RosCaptureError:
                self.stop()
                raise
            log = open(self.log_dir / f"{CONTROLLER}.log", "wb")
            self._logs[CONTROLLER] = log
            self.procs[CONTROLLER] = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT,
                                                      stdin=subprocess.DEVNULL, env=self.env,
                                                      start_new_session=True)
        try:
            self._start_client()
            deadline = time.monotonic() + timeout
            while not (self._client.wait_for_service(timeout_sec=0.1) and not self.missing()):
                self.check_alive("while starting")
                if time.monotonic() > deadline:
                    raise RosCaptureError(f"timed out after {timeout:g} s waiting for the suite: "
                                          f"{self.missing() or 'no RunCapture service'} "
                                          f"(logs: {self.log_dir})")
            self._wait_capture_node_ready(deadline, timeout)
            # every writer has matched the readers the nodes count, but a reader matches its
            # writers on its own schedule, which no other node can see: the setup is sent
            # until the episode runs (the setup handshake), and this grace lets the states'
            # readers match before the first episode (docs/ros.md)
            time.sleep(READER_GRACE_S)
        except BaseException:
            self.stop()
            raise
        return self

    def _wait_capture_node_ready(self, deadline: float, timeout: float) -> None:
        """Wait until the capture node itself sees the whole suite (its suite_ready
        service); this client's view of the graph can be complete before the capture
        node's is (seen on a loaded CI machine: > 10 s apart)."""
        from std_srvs.srv import Trigger

        client = self._node.create_client(Trigger, READY_SERVICE)
        try:
            message = "no suite_ready service"
            while time.monotonic() <= deadline:
                self.check_alive("while starting")
                if client.wait_for_service(timeout_sec=0.1):
                    future = client.call_async(Trigger.Request())
                    if self.spin_until(future.done, timeout=5.0):
                        reply = future.result()
                        if reply.success:
                            return
                        message = reply.message
                    else:
                        client.remove_pending_request(future)
                    time.sleep(0.2)
            raise RosCaptureError(f"timed out after {timeout:g} s waiting for the suite: the "
                                  f"capture node reports {message} (logs: {self.log_dir})")
        finally:
            self._node.destroy_client(client)

    def _start_client(self) -> None:
        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        from tethernet_msgs.msg import CaptureMetrics
        from tethernet_msgs.srv import RunCapture

        from .qos import state_qos

        self._context = rclpy.Context()
        self._context.init(domain_id=int(self.env["ROS_DOMAIN_ID"]))
        self._node = rclpy.create_node(f"tethernet_client_{os.getpid()}_{self.env['ROS_DOMAIN_ID']}",
                                       context=self._context)
        self._executor = SingleThreadedExecutor(context=self._context)
        self._executor.add_node(self._node)
        self._client = self._node.create_client(RunCapture, SERVICE)
        self._node.create_subscription(CaptureMetrics, TOPICS["metrics"],
                                       self._metrics.append, state_qos(1000))

    def missing(self) -> str:
        """'' if every suite topic has its subscribers and publishers in the graph."""
        out = []
        subscribers, publishers = dict(REQUIRED_SUBSCRIBERS), list(REQUIRED_PUBLISHERS)
        if self.lockstep:
            subscribers.update(LOCKSTEP_SUBSCRIBERS)
            publishers += LOCKSTEP_PUBLISHERS
        for key, n in subscribers.items():
            if self._node.count_subscribers(TOPICS[key]) < n:
                out.append(f"{TOPICS[key]} lacks subscribers")
        for key in publishers:
            if self._node.count_publishers(TOPICS[key]) < 1:
                out.append(f"no publisher on {TOPICS[key]}")
        return "; ".join(out)

    def log_tail(self, name: str, lines: int = 5) -> str:
        try:
            text = (self.log_dir / f"{name}.log").read_text(errors="replace").strip().splitlines()
        except OSError:
            return ""
        return " | ".join(line.strip() for line in text[-lines:])

    def check_alive(self, when: str = "during the capture") -> None:
        for name, proc in self.procs.items():
            code = proc.poll()
            if code is not None:
                tail = self.log_tail(name)
                raise RosCaptureError(f"{name} (pid {proc.pid}) stopped {when} "
                                      f"({_signal_text(code)})" + (f"; log: {tail}" if tail else ""))

    def kill(self, name: str, sig: int = signal.SIGKILL) -> None:
        """Send a signal to one node (fault-injection for tests)."""
        os.kill(self.procs[name].pid, sig)

    def stop(self, timeout: float = 10.0) -> dict[str, int]:
        """Stop every node: SIGINT, then SIGTERM, then SIGKILL.  Returns exit statuses."""
        for proc in self.procs.values():
            if proc.poll() is None:
                try:
                    proc.send_signal(signal.SIGINT)
                except ProcessLookupError:
                    pass
        deadline = time.monotonic() + timeout
        codes = {}
        for name, proc in self.procs.items():
            for sig in (None, signal.SIGTERM, signal.SIGKILL):
                if sig is not None and proc.poll() is None:
                    proc.send_signal(sig)
                try:
                    proc.wait(timeout=max(0.1, deadline - time.monotonic()) if sig is None else 3.0)
                    break
                except subprocess.TimeoutExpired:
                    continue
            codes[name] = proc.returncode
        for log in self._logs.values():
            log.close()
        self._logs = {}
        if self._node is not None:
            self._executor.shutdown()
            self._node.destroy_node()
            self._context.try_shutdown()
            self._node = self._context = self._executor = None
        self.procs = {}
        return codes

    def __enter__(self) -> RosSuite:
        return self.start() if not self.procs else self

    def __exit__(self, *exc) -> None:
        self.stop()
        if self._tmp is not None and exc[0] is None:
            self._tmp.cleanup()

    # -- requests ------------------------------------------------------------------------
    def request(self, design: Design, seed: int | None, noise_model: NoiseModel | None = None,
                record_bag: bool = True, bag_name: str | None = None, tumble=None,
                target: str = "", target_mass: float = 0.0, launch=None,
                criterion: str = "", tow_acceleration: float = 0.0, target_units: str = ""):
        """A RunCapture request; ``tumble`` (a TumbleConfig): the target's spin for this
        episode (None: the suite's configuration's); ``target``: a catalogue name or mesh
        file ('' the suite's configuration's), its mass (kg; 0: the catalogue's) and a mesh
        file's length unit (``target_units``; '': the configured target's, else m);
        ``launch`` (a LaunchConfig): its launch policy, max_wait and max_tilt_deg (None: the
        suite's configuration's; its other settings must be the configuration's, which the
        request cannot carry); ``criterion`` ('source' or 'held'; '' the configuration's) and
        ``tow_acceleration`` (m/s^2; 0 the configuration's): docs/model.md §17."""
        from tethernet_msgs.srv import RunCapture

        req = RunCapture.Request()
        req.design = conv.design_msg(design)
        req.nominal = seed is None
        req.seed = 0 if seed is None else int(seed)
        req.noise = conv.noise_settings_msg(noise_model or self.noise_model)
        req.record_bag = bool(record_bag)
        req.bag_name = bag_name or ""
        if tumble is not None:
            req.set_tumble = True
            req.tumble = conv.tumble_msg(tumble)
        req.target, req.target_mass = str(target), float(target_mass)
        req.target_units = str(target_units)
        if launch is not None:
            self._check_launch(launch)
            req.set_launch = True
            for name, field in conv.LAUNCH_REQUEST_FIELDS.items():
                setattr(req, field, getattr(launch, name))
        req.criterion, req.tow_acceleration = str(criterion), float(tow_acceleration)
        return req

    def _check_launch(self, launch) -> None:
        """Refuse a LaunchConfig whose settings a request cannot carry (those outside
        conversions.LAUNCH_REQUEST_FIELDS) and that differ from the suite's configuration:
        they would be lost."""
        from dataclasses import fields

        mine = self.config.launch
        lost = [f.name for f in fields(launch) if f.name not in conv.LAUNCH_REQUEST_FIELDS
                and getattr(launch, f.name) != getattr(mine, f.name)]
        if lost:
            raise ValueError(
                f"launch: {', '.join(lost)} cannot be set per request (the suite's "
                f"configuration holds {', '.join(f'{n}={getattr(mine, n)!r}' for n in lost)}); "
                "start the suite with a configuration that has them")

    def set_parameters(self, node: str, values: dict, timeout: float = 10.0) -> list[str]:
        """Set parameters of one of the suite's nodes (as ``ros2 param set`` does; they
        take effect at its next episode); the reasons of those refused ('' if set)."""
        from rcl_interfaces.srv import SetParameters
        from rclpy.parameter import Parameter

        client = self._node.create_client(SetParameters, f"/{node}/set_parameters")
        try:
            if not client.wait_for_service(timeout_sec=timeout):
                raise RosCaptureError(f"{node}: no set_parameters service within {timeout:g} s")
            request = SetParameters.Request(
                parameters=[Parameter(k, value=v).to_parameter_msg() for k, v in values.items()])
            future = client.call_async(request)
            if not self.spin_until(future.done, timeout):
                client.remove_pending_request(future)
                raise RosCaptureError(f"{node}: set_parameters did not answer within {timeout:g} s")
            return [r.reason if not r.successful else "" for r in future.result().results]
        finally:
            self._node.destroy_client(client)

    def spin_until(self, predicate, timeout: float) -> bool:
        """Spin the client until ``predicate()`` is true (or timeout s); returns it."""
        deadline = time.monotonic() + timeout
        while not predicate() and time.monotonic() < deadline:
            self._executor.spin_once(timeout_sec=0.01)
        return bool(predicate())

    @property
    def client(self):
        return self._client

    @property
    def metrics(self) -> list:
        """CaptureMetrics received by the client during the last call."""
        return self._metrics

    def call(self, request, timeout: float = 900.0, check_processes: bool = True,
             cancel: threading.Event | None = None):
        """Send a RunCapture request; the response (raises RosCaptureError on timeout,
        once ``cancel`` is set, or, if ``check_processes``, when a node process dies).  A
        cancelled call leaves its episode running in the nodes, whose states and response
        would mix with the next call's: the suite then refuses calls until it is stopped
        and started again."""
        if self._abandoned:
            raise RosCaptureError("this suite abandoned an episode (a cancelled call) that its "
                                  "nodes may still run: stop() and start() it first")
        self._metrics.clear()
        future = self._client.call_async(request)
        deadline = time.monotonic() + timeout
        while not future.done():
            self._executor.spin_once(timeout_sec=0.05)
            if check_processes:
                self.check_alive()
            if cancel is not None and cancel.is_set():
                self._client.remove_pending_request(future)
                self._abandoned = True
                raise RosCaptureError("cancelled: the run stopped before the episode ended")
            if time.monotonic() > deadline:
                self._client.remove_pending_request(future)
                raise RosCaptureError(f"timed out after {timeout:g} s waiting for the RunCapture "
                                      f"response (logs: {self.log_dir})")
        resp = future.result()
        # the last state's metrics may still be queued: wait (1 s at most) until they are in
        if resp.status == SUCCEEDED:
            final = resp.result.header.stamp.sec + 1e-9 * resp.result.header.stamp.nanosec
            self.spin_until(lambda: bool(self._metrics) and self._metrics[-1].sim_time >= final - 1e-6,
                            timeout=1.0)
        return resp

    def capture(self, design: Design, seed: int | None, noise_model: NoiseModel | None = None,
                record_bag: bool = True, bag_name: str | None = None,
                timeout: float = 900.0, tumble=None, target: str = "",
                target_mass: float = 0.0, launch=None, criterion: str = "",
                tow_acceleration: float = 0.0,
                target_units: str = "") -> tuple[EpisodeResult, str | None]:
        resp = self.call(self.request(design, seed, noise_model, record_bag, bag_name, tumble,
                                      target, target_mass, launch, criterion,
                                      tow_acceleration, target_units), timeout)
        if resp.status == REJECTED:
            raise RosCaptureError(f"request refused: {resp.error}")
        if resp.status != SUCCEEDED:
            raise RosCaptureError(f"{STATUS_NAMES.get(resp.status, resp.status)}: {resp.error}"
                                  + (f" (bag: {resp.bag_path})" if resp.bag_path else ""))
        result = conv.episode_result_from_msg(resp.result)
        result.trace = self._trace()
        if result.trace.time and math.isfinite(result.settled_cqi):
            last = self._metrics[-1]
            if last.sim_time == result.completion_time:
                result.settled_terms = conv.terms_from_msg(last)
        return result, (resp.bag_path or None)

    def _trace(self) -> EpisodeTrace:
        tr = EpisodeTrace()
        for m in sorted(self._metrics, key=lambda m: m.sim_time):
            tr.time.append(m.sim_time)
            tr.cqi.append(m.cqi)
            tr.volume_term.append(m.volume_term)
            tr.area_term.append(m.area_term)
            tr.distance_term.append(m.distance_term)
            tr.locked_pairs.append(m.locked_pairs)
        return tr


def capture_via_ros(design: Design, seed: int | None = None, noise_model: NoiseModel | None = None,
                    config: SimConfig | None = None, record_bag: bool = True,
                    bag_name: str | None = None, timeout: float = 900.0,
                    bag_dir: str | Path = "bags", params: dict | None = None,
                    lockstep: bool = False, controller: str | None = None
                    ) -> tuple[EpisodeResult, str | None]:
    """One capture through a fresh node suite (nodes as processes); ``lockstep`` and
    ``controller`` as :class:`RosSuite` has them.

    Returns (result, bag path or None).  The result's ``trace`` holds the monitor's
    CaptureMetrics series; every other field is the library's, bit for bit.  Raises
    RosCaptureError (one line) if a node dies, the service refuses the request, or the
    episode times out.
    """
    suite = RosSuite(config=config, noise_model=noise_model, bag_dir=bag_dir, params=params,
                     lockstep=lockstep, controller=controller)
    with suite:
        return suite.capture(design, seed, noise_model, record_bag=record_bag,
                             bag_name=bag_name, timeout=timeout)
