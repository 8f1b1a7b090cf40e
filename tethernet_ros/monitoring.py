"""Metrics and verdict of *received* states, with the core's functions (no ROS import).

The monitor node and ``tethernet replay`` both see the episode only as a sequence of
states (NetState messages).  :class:`StateMirror` is a :class:`CaptureSimulation` built
from the same design, commands and configuration as the simulation's, but never advanced:
each received state is loaded into its arrays, and then the core's own ``cqi()``,
``locked_pairs``, ``divergence()``, ``end_step()`` and ``episode_result`` result rules
apply to it unchanged.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from .core import kernel as kn
from .core.config import SimConfig
from .core.design import Design
from .core.kernel.policy_table import controller_policy
from .core.episode import CaptureSimulation, EpisodeClock, EpisodeResult, episode_result
from .core.metrics import CQITerms
from .core.scenario import Actions, World, build_scenario


class StateError(ValueError):
    """A received state does not fit the episode's scenario (one line)."""


class StateMirror:
    def __init__(self, design: Design, actions: Actions, world: World, config: SimConfig):
        self.design = design
        self.config = config
        # (never advanced: its launch is left to the states it loads, not waited for)
        mirror = config.replace(launch=replace(config.launch, kind=controller_policy("launch"))) \
            if config.launch.built_in else config
        # states cannot be pulled: the verdict of states is the source's criterion's
        # (the simulation's result carries the tug's; ros/results.py:compare_results)
        mirror = mirror.replace(criterion="source")
        self.sim = CaptureSimulation(build_scenario(design, actions, world, mirror))
        # run_simulation tests for divergence at its clock's steps (and at the end step); a
        # verdict on divergence is taken at those steps only, as there
        self.check_every = EpisodeClock(config, self.sim.dt).chunk

    @property
    def dt(self) -> float:
        return self.sim.dt

    def load(self, st) -> None:
        """Load a :class:`~tethernet_ros.ros.state.StateArrays` into the mirror."""
        s = self.sim.s
        b, t, ring = s.bodies, s.target_body, s.drawstring
        if st.positions.shape != b.x.shape or st.velocities.shape != b.v.shape:
            raise StateError(f"state of {st.positions.shape[0]} bodies; the scenario has "
                             f"{b.x.shape[0]}")
        if st.locked.shape != ring.locked.shape:
            raise StateError(f"state with {st.locked.shape[0]} closing pairs; the scenario has "
                             f"{ring.locked.shape[0]}")
        b.x[:] = st.positions
        b.v[:] = st.velocities
        t.pos[:] = st.target_position
        t.quat[:] = st.target_quaternion
        t.vel[:] = st.target_velocity
        t.omega[:] = st.target_omega
        ring.locked[:] = st.locked
        # the state's step and closing time are on the mission's clock; the episode's
        # rules count the flight's steps (docs/model.md §16)
        launch = int(getattr(st, "launch_step", 0))
        s.events[kn.E_LAUNCH_STEP] = launch
        s.events[kn.E_LAUNCHED] = 1
        s.events[kn.E_STEP] = st.step - launch
        s.events[kn.E_CLOSING_ACTIVE] = 1 if st.closing_active else 0
        s.events[kn.E_CLOSING_STEP] = int(round(st.closing_start_time / self.sim.dt)) - launch \
            if st.closing_active else -1

    def terms(self) -> CQITerms | None:
        """CQI terms of the loaded state (None if the state is not finite)."""
        s = self.sim.s
        if not (np.all(np.isfinite(s.bodies.x[s.net_nodes]))
                and np.all(np.isfinite(s.target_body.pos))):
            return None
        return self.sim.cqi()

    @property
    def locked_pairs(self) -> int:
        return self.sim.locked_pairs

    @property
    def closing_active(self) -> bool:
        return self.sim.closing_active

    def verdict(self) -> EpisodeResult | None:
        """The episode's result if the loaded state ends it (closing + settle time, the
        horizon, or divergence at one of run_simulation's check steps), else None.
        ``max_penetration`` is not observable from states (NaN)."""
        sim = self.sim
        end = sim.end_step()
        at_end = sim.step >= end
        if at_end or (sim.step > 0 and sim.step % self.check_every == 0):
            reason = sim.divergence()
            if reason:
                res = episode_result(sim, reason)
                res.max_penetration = math.nan
                return res
        if not at_end:
            return None
        # the state is at its end step: the core's result rules (closing never triggered /
        # capture_verdict) apply to it
        res = episode_result(sim)
        res.max_penetration = math.nan
        return res
