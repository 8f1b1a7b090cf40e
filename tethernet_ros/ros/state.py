"""What the nodes hold between messages: the episode's setup, the setups already handled,
the actuator's commands waiting for their setup, and state snapshots of a running simulation.  No ROS import."""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from ..core.config import SimConfig
from ..core.design import Design
from ..core.noise import NoiseModel


@dataclass(frozen=True)
class Setup:
    """An EpisodeSetup in core terms.  seed None: nominal (no noise); noise_scales: scale
    factor per noise source (None when nominal); stamp: (sec, nanosec) of the setup's
    header, the key that ties the actuator's commands to it; request_seed: the seed the
    request gave, which results report (also when nominal, where no noise is drawn);
    lockstep: the capture node asked for the closing policy to run through ROS (see
    :func:`.loop.runs_in_lockstep`, which also says so for the policy 'external')."""

    episode_id: str
    design: Design
    seed: int | None
    noise_scales: dict | None
    orientation_axis: str
    config: SimConfig
    stamp: tuple[int, int]
    request_seed: int = 0
    lockstep: bool = False

    def noise_model(self, spreads: dict | None = None) -> NoiseModel | None:
        """The episode's NoiseModel with the given spreads (None when nominal)."""
        if self.seed is None:
            return None
        return NoiseModel(orientation_axis=self.orientation_axis, scales=self.noise_scales,
                          **(spreads or {}))


def stamp_key(header) -> tuple[int, int]:
    """(sec, nanosec) of a message header's stamp."""
    return int(header.stamp.sec), int(header.stamp.nanosec)


class CommandBuffer:
    """The latest launch and closing commands per episode stamp (a few episodes kept):
    a command may arrive before the EpisodeSetup it answers (different writers)."""

    def __init__(self, keep: int = 8):
        self.keep = keep
        self._by_stamp: dict[tuple[int, int], dict] = {}

    def put(self, header, kind: str, msg) -> None:
        """Keep ``msg``, a "launch" or "closing" command, under its header's stamp."""
        self._by_stamp.setdefault(stamp_key(header), {})[kind] = msg
        while len(self._by_stamp) > self.keep:
            self._by_stamp.pop(next(iter(self._by_stamp)))

    def get(self, key: tuple[int, int]):
        """(launch, closing) of the episode stamped ``key``; None for one not yet heard."""
        d = self._by_stamp.get(tuple(key), {})
        return d.get("launch"), d.get("closing")


@dataclass
class StateArrays:
    """One NetState as arrays (SI; quaternion w, x, y, z); also the snapshot of a running
    simulation that the sim node hands to its publishing thread."""

    step: int
    sim_time: float
    positions: np.ndarray       # (N, 3) m
    velocities: np.ndarray      # (N, 3) m/s
    target_position: np.ndarray
    target_quaternion: np.ndarray
    target_velocity: np.ndarray
    target_omega: np.ndarray    # rad/s
    closing_active: bool
    closing_start_time: float   # s; -1 before closing
    locked: np.ndarray          # (12,) bool
    num_net_nodes: int = 0
    num_corner_masses: int = 0
    launch_step: int = 0        # steps waited before the launch (``step`` includes them)


def state_arrays(sim) -> StateArrays:
    """Snapshot (copies) of a CaptureSimulation's current state (the kernel's named state)."""
    s = sim.s
    b, t = s.bodies, s.target_body
    ct = sim.closing_time
    return StateArrays(
        step=sim.mission_step, sim_time=sim.time,
        launch_step=sim.launch_step,
        positions=np.array(b.x, dtype=float), velocities=np.array(b.v, dtype=float),
        target_position=np.array(t.pos, dtype=float),
        target_quaternion=np.array(t.quat, dtype=float),
        target_velocity=np.array(t.vel, dtype=float),
        target_omega=np.array(t.omega, dtype=float),
        closing_active=sim.closing_active,
        closing_start_time=-1.0 if ct is None else float(ct),
        locked=np.array(s.drawstring.locked, dtype=bool),
        num_net_nodes=len(s.net_nodes), num_corner_masses=len(s.corner_bodies))


class SetupsHeard:
    """The last few EpisodeSetups a node handled, by key (episode id, stamp).  The capture
    node sends an episode's setup again until it sees the episode running (docs/ros.md,
    "the setup handshake"), so a setup heard before is a repeat, to be ignored (the
    actuator sends its commands for the latest one again)."""

    def __init__(self, keep: int = 8):
        self._keys: deque = deque(maxlen=keep)

    @staticmethod
    def key(msg) -> tuple[str, int, int]:
        return (str(msg.episode_id), *stamp_key(msg.header))

    def repeat(self, msg) -> bool:
        """True if ``msg`` was heard before; else note it and answer False."""
        key = self.key(msg)
        if key in self._keys:
            return True
        self._keys.append(key)
        return False

    def is_latest(self, msg) -> bool:
        """True if ``msg`` is the last setup noted."""
        return bool(self._keys) and self._keys[-1] == self.key(msg)
