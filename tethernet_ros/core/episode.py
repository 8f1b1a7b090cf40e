"""One capture episode as one call: ``run_episode(design, sample, config)``.

:class:`CaptureSimulation` is the stepping interface shared by ``run_episode`` and the ROS
simulation node, so both advance the same kernel through the same steps and give the same
numbers bit for bit.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, asdict

import numpy as np

from . import kernel as kn
from .config import SimConfig
from .design import Design
from .metrics import (NOT_HELD, CQITerms, capture_quality_index, capture_verdict, clear_success,
                      criterion_of)
from .noise import NoiseSample
from .scenario import (Actions, Scenario, World, actions_for, advance_kernel, build_scenario,
                       world_for)
from .kernel.model import steps_every
from .kernel.sensing import seed_state
from .tug import TugTest


class CaptureSimulation:
    """One episode of a :class:`Scenario`: advances it with the numba kernel (a batch of
    one lane), or, inside a batch (:mod:`tethernet_ros.core.batch`), reads its lane.

    Time is kept as integer step counts: ``step`` the flight's, from the launch (the
    horizon and the settle count from it); ``launch_step`` the steps the chaser waited
    before firing (``core.launch``); ``time`` = (launch_step + step) * dt (s), the
    mission's time, from the first moment the chaser could have fired.
    """

    def __init__(self, scenario: Scenario):
        self.s = scenario
        self.cfg = scenario.config
        self.dt = scenario.dt
        self.model, self.data = scenario.kernel()
        self.scratch = kn.new_scratch(self.model, 1) if kn.lane_count(self.data) == 1 else None
        self.net_masses = scenario.bodies.mass[scenario.net_nodes].copy()
        self.settle_steps = int(round(self.cfg.settle_time / self.dt))
        #: the early call (config.py): steps from closing activation to its check (None:
        #: off), and whether it was checked
        self.call_steps = (int(round(0.5 * self.cfg.settle_time / self.dt))
                           if self.cfg.early_call else None)
        self.call_checked = False
        self.horizon_steps = int(round(self.cfg.horizon / self.dt))
        #: the tug test after the settle time (None: off), and what was read when it began
        self.tug = TugTest(self, self.cfg.tug) if self.cfg.tug.enabled else None
        self.settled: tuple[CQITerms, int] | None = None

    # -- state ---------------------------------------------------------------------
    @property
    def step(self) -> int:
        return int(self.s.events[kn.E_STEP])

    @property
    def launch_step(self) -> int:
        return int(self.s.events[kn.E_LAUNCH_STEP])

    @property
    def launch_time(self) -> float:
        """How long the chaser waited before firing (s)."""
        return self.launch_step * self.dt

    @property
    def mission_step(self) -> int:
        """The step on the mission's clock: the steps waited plus the flight's (the
        kernel's ``measure.mission_step``)."""
        return self.launch_step + self.step

    @property
    def time(self) -> float:
        return self.mission_step * self.dt

    @property
    def closing_active(self) -> bool:
        return bool(self.s.events[kn.E_CLOSING_ACTIVE])

    @property
    def closing_step(self) -> int | None:
        return int(self.s.events[kn.E_CLOSING_STEP]) if self.closing_active else None

    @property
    def closing_time(self) -> float | None:
        cs = self.closing_step
        return None if cs is None else (self.launch_step + cs) * self.dt

    @property
    def locked_pairs(self) -> int:
        return int(self.s.drawstring.locked.sum())

    def end_step(self) -> int:
        """Step at which the episode, or its current phase, ends as things stand now: the
        horizon without closing, the settle time after it, then the tug test's phases."""
        cs = self.closing_step
        if cs is None:
            return self.horizon_steps
        if self.tug is not None and self.tug.started:
            return self.tug.end_step()
        if self.call_steps is not None and not self.call_checked:
            return cs + self.call_steps
        return cs + self.settle_steps

    def next_phase(self) -> bool:
        """At :meth:`end_step`: begin the next phase, if any (True: the episode goes on).
        With the early call, at half the settle time a clear success is read as the
        settled state (``settled``) and ends the episode; anything else settles on.  At the
        end of the settle time the capture's verdict state is read (``settled``) and the
        tug test, when on, starts; its phases follow (``tug.TugTest``)."""
        if self.closing_active and self.call_steps is not None and not self.call_checked:
            self.call_checked = True
            terms, pairs = self.cqi(), self.locked_pairs
            if clear_success(terms.cqi, pairs, len(self.s.drawstring.locked),
                             self.cfg.success_cqi):
                self.settled = (terms, pairs)
                return False
            return True
        if not self.closing_active or self.tug is None:
            return False
        if not self.tug.started:
            terms, pairs = self.cqi(), self.locked_pairs
            self.settled = (terms, pairs)
            if self.cfg.criterion == "held" and not capture_verdict(
                    terms.cqi, pairs, self.cfg.success_cqi, self.cfg.success_locked_pairs)[0]:
                return False        # criterion 'held': the tug tests the source's successes only
            self.tug.start()
            return True
        return self.tug.advance_phase()

    @property
    def launched(self) -> bool:
        """Whether the net has left (an in-kernel launch policy has fired by the time the
        simulation exists; 'external' waits for :meth:`fire`)."""
        return bool(self.s.events[kn.E_LAUNCHED])

    def fire(self) -> None:
        """Launch now (a controller outside the kernel decided: launch policy 'external')."""
        from .kernel.launch import fire
        fire(self.data, self.s.lane)

    def hold(self) -> None:
        """Do not launch at this step: the target turns one step on, the net stays stowed."""
        from .kernel.launch import hold
        if self.launched:
            raise RuntimeError("the net has already left: it cannot be held")
        hold(self.s.kernel()[0], self.data, self.scratch, self.s.lane)

    def advance(self, n_steps: int) -> None:
        """Advance ``n_steps`` integration steps (mutates the scenario arrays).  A lane of a
        batch is advanced by its batch, not here."""
        if n_steps <= 0:
            return
        if self.scratch is None:
            raise RuntimeError("a lane of a batch is advanced by the batch")
        if not self.launched:
            raise RuntimeError("the net has not left: the launch policy 'external' needs a "
                               "controller outside the kernel to fire it (fire())")
        model = self.s.kernel()[0]   # set_params may have rebuilt it
        advance_kernel(self.cfg, model, self.data, self.scratch, n_steps)

    def command_closing(self) -> bool:
        """Start closing now, as a controller outside the kernel commands it (policy
        'external'): the same as the kernel's own policy deciding at this step.  False if
        closing was already active or is not armed."""
        from .kernel.events import command_closing
        return bool(command_closing(self.s.kernel()[0], self.data, self.s.lane))

    @property
    def contact_count(self) -> int:
        """Body-steps spent in contact with the target so far."""
        return int(self.data.contact_count[self.s.lane])

    @property
    def max_penetration(self) -> float:
        """Deepest penetration of a body into the target so far (m)."""
        return float(self.data.max_penetration[self.s.lane])

    def divergence(self) -> str:
        """'' if the state is sound, else why the simulation diverged."""
        b, t = self.s.bodies, self.s.target_body
        if not (np.all(np.isfinite(b.x)) and np.all(np.isfinite(b.v))
                and np.all(np.isfinite(t.pos)) and np.all(np.isfinite(t.quat))):
            return f"simulation diverged: non-finite state at t = {self.time:.3f} s"
        v = b.v
        if self.tug is not None and self.tug.started:    # the tug test: in the chaser's frame
            v = v - v[self.s.tether.winch]
        vmax = float(np.sqrt((v**2).sum(axis=1)).max())
        if vmax > self.cfg.max_speed:
            return (f"simulation diverged: body speed {vmax:.1f} m/s > max_speed "
                    f"{self.cfg.max_speed:g} m/s at t = {self.time:.3f} s")
        return ""

    def net_positions(self) -> np.ndarray:
        return self.s.bodies.x[self.s.net_nodes]

    def net_centre_of_mass(self) -> np.ndarray:
        return (self.net_positions() * self.net_masses[:, None]).sum(axis=0) / self.net_masses.sum()

    def cqi(self) -> CQITerms:
        t = self.s.target
        return capture_quality_index(self.net_positions(), self.net_masses, self.s.target_body.pos,
                                     t.volume, t.area, t.min_surface_distance)

    # -- conserved quantities (for verification) ------------------------------------
    def dynamic_bodies(self) -> np.ndarray:
        return np.flatnonzero(self.s.bodies.w > 0)

    def linear_momentum(self) -> np.ndarray:
        """Total linear momentum (kg m/s) of dynamic bodies and target."""
        s, t = self.s.bodies, self.s.target_body
        b = self.dynamic_bodies()
        return (s.mass[b, None] * s.v[b]).sum(axis=0) + self.target_mass * t.vel

    @property
    def target_mass(self) -> float:
        """The target's mass in this episode (kg; drawn when the noise model says so)."""
        return 1.0 / float(self.s.target_body.inv_mass)

    def kinetic_energy(self) -> float:
        s, t = self.s.bodies, self.s.target_body
        b = self.dynamic_bodies()
        ke = 0.5 * float((s.mass[b] * (s.v[b] ** 2).sum(axis=1)).sum())
        ke += 0.5 * self.target_mass * float(t.vel @ t.vel)
        R = kn.quat_to_matrix(t.quat)
        wb = R.T @ t.omega
        ke += 0.5 * float((t.inertia * wb**2).sum())
        return ke

    def elastic_energy(self) -> float:
        """Strain energy (J) of stretched threads and tether segments."""
        s = self.s
        pairs, rest, k, _, active = s.threads()
        act = active == 1
        a, b = pairs[act, 0], pairs[act, 1]
        x = s.bodies.x
        stretch = np.maximum(np.linalg.norm(x[b] - x[a], axis=1) - rest[act], 0.0)
        return float((0.5 * k[act] * stretch**2).sum())


@dataclass
class EpisodeTrace:
    """Time series at the metric rate (time in s) and node positions at the state rate."""

    time: list = field(default_factory=list)
    cqi: list = field(default_factory=list)
    volume_term: list = field(default_factory=list)
    area_term: list = field(default_factory=list)
    distance_term: list = field(default_factory=list)
    locked_pairs: list = field(default_factory=list)
    z_rel: list = field(default_factory=list)
    state_time: list = field(default_factory=list)
    positions: list = field(default_factory=list)      # each (N_bodies, 3)
    target_pose: list = field(default_factory=list)    # each [x, y, z, qw, qx, qy, qz]


#: The fields of an episode's result that leave the process (JSON, results files, ROS
#: messages), in this order: the one home of the list.
RESULT_FIELDS: tuple[str, ...] = ("success", "settled_cqi", "locked_pairs", "closing_time",
                                  "completion_time", "mass", "failure_reason", "wall_time",
                                  "seed", "steps", "max_penetration", "settled_terms",
                                  "launch_time", "tug", "criterion")


@dataclass
class EpisodeResult:
    """Outcome of one capture.  Times in s, from the first moment the chaser could have
    fired (``launch_time``: how long it waited); mass in kg; NaN where undefined."""

    success: bool
    settled_cqi: float
    locked_pairs: int
    closing_time: float
    completion_time: float
    mass: float
    failure_reason: str
    wall_time: float
    seed: int | None
    steps: int
    max_penetration: float
    settled_terms: dict | None = None
    launch_time: float = 0.0
    tug: dict | None = None
    #: the success criterion that judged ``success`` (config.py: 'source', the settled CQI
    #: and locked pairs; 'held', those and the tug test at the required pull)
    criterion: str = "source"
    trace: EpisodeTrace | None = None

    def to_dict(self, with_trace: bool = False) -> dict:
        d = {k: getattr(self, k) for k in RESULT_FIELDS}
        for k in ("settled_cqi", "closing_time", "completion_time"):
            if isinstance(d[k], float) and not math.isfinite(d[k]):
                d[k] = None
        if with_trace and self.trace is not None:
            t = asdict(self.trace)
            t["positions"] = [p.tolist() for p in self.trace.positions]
            d["trace"] = t
        return d


class EpisodeClock:
    """When an episode is looked at: the metric samples (every ``metric_every`` steps),
    the state samples (``state_every``, 0: none) and the checks for divergence and for its
    end (every ``chunk`` steps, the steps of both kinds of sample), up to its end.  The one
    home of these rules for single episodes, batch lanes and the ROS simulation node."""

    def __init__(self, cfg: SimConfig, dt: float):
        self.metric_every = steps_every(cfg.metric_rate, dt)
        self.state_every = steps_every(cfg.state_rate, dt) if cfg.state_rate > 0 else 0
        self.chunk = (self.metric_every if not self.state_every
                      else math.gcd(self.metric_every, self.state_every))

    def next_stop(self, step: int, end: int) -> int:
        """The next step at which to look: the next multiple of ``chunk``, or the end."""
        return min((step // self.chunk + 1) * self.chunk, end)


class EpisodeRecorder:
    """The trace of an episode (if asked) and the observer's calls, at the clock's steps."""

    def __init__(self, sim: CaptureSimulation, clock: EpisodeClock, record_trace: bool,
                 observer=None):
        self.sim = sim
        self.clock = clock
        self.trace = EpisodeTrace() if record_trace else None
        self.observer = observer

    def sample(self, step: int) -> None:
        """Record what is due at ``step`` (the simulation's current step)."""
        trace, observer, sim = self.trace, self.observer, self.sim
        if trace is None and observer is None:
            return
        metric_every, state_every = self.clock.metric_every, self.clock.state_every
        if trace is not None and step % metric_every == 0:
            terms = sim.cqi()
            trace.time.append(sim.time)
            trace.cqi.append(terms.cqi)
            trace.volume_term.append(terms.volume_term)
            trace.area_term.append(terms.area_term)
            trace.distance_term.append(terms.distance_term)
            trace.locked_pairs.append(sim.locked_pairs)
            trace.z_rel.append(float(sim.net_centre_of_mass()[2] - sim.s.target_body.pos[2]))
        if trace is not None and state_every and step % state_every == 0:
            trace.state_time.append(sim.time)
            trace.positions.append(sim.s.bodies.x.copy())
            trace.target_pose.append([*sim.s.target_body.pos, *sim.s.target_body.quat])
        if observer is not None and step % metric_every == 0:
            observer(sim)


def after_stop(sim: CaptureSimulation, recorder: EpisodeRecorder) -> tuple[bool, str]:
    """What an episode does when it reaches one of its clock's steps: (ended, reason) --
    ended on divergence (with its reason) or at its end step, else its samples taken."""
    reason = sim.divergence()
    if reason:
        if sim.settled is not None:          # during the tug test: the capture's verdict stands
            sim.tug.end_early(f"the test ended early: {reason}")
            return True, ""
        return True, reason
    recorder.sample(sim.step)
    if sim.step < sim.end_step():
        return False, ""
    return not sim.next_phase(), ""


def run_simulation(sim: CaptureSimulation, record_trace: bool = True, observer=None) -> EpisodeResult:
    """Run a prepared simulation to its end: closing activation + settle time, the horizon
    without closing, or divergence.  ``observer(sim)`` is called at every metric sample."""
    t0 = time.perf_counter()
    clock = EpisodeClock(sim.cfg, sim.dt)
    rec = EpisodeRecorder(sim, clock, record_trace, observer)
    rec.sample(sim.step)
    reason = ""
    ended = sim.step >= sim.end_step()
    while not ended:
        sim.advance(clock.next_stop(sim.step, sim.end_step()) - sim.step)
        ended, reason = after_stop(sim, rec)
    return episode_result(sim, reason, time.perf_counter() - t0, rec.trace)


def episode_result(sim: CaptureSimulation, reason: str = "", wall_time: float = 0.0,
                   trace: EpisodeTrace | None = None) -> EpisodeResult:
    """The result rules applied to the simulation's current state: diverged (``reason``
    given), closing never triggered (T is the horizon), or the capture verdict of the
    settled state.  The one home of these rules (library, workers, monitor node)."""
    cfg = sim.cfg
    mass = sim.s.design.mass(cfg.density)
    settled = None
    if reason:
        success, cqi_val, n_l = False, math.nan, sim.locked_pairs
        completion = sim.time
    elif not sim.closing_active:
        success, cqi_val, n_l = False, math.nan, sim.locked_pairs
        reason = f"closing never triggered within the {cfg.horizon:g} s horizon"
        completion = sim.launch_time + cfg.horizon
    else:
        terms, n_l = sim.settled if sim.settled is not None else (sim.cqi(), sim.locked_pairs)
        settled = terms.to_dict()
        cqi_val = terms.cqi
        success, reason = capture_verdict(cqi_val, n_l, cfg.success_cqi, cfg.success_locked_pairs)
        if success and cfg.criterion == "held":
            success, reason = held_verdict(sim)
        # T: the settle time after closing starts (docs/model.md §7), also when the early
        # call read the state sooner
        completion = (sim.launch_step + sim.closing_step + sim.settle_steps) * sim.dt
    return EpisodeResult(
        success=success, settled_cqi=cqi_val, locked_pairs=n_l,
        closing_time=sim.closing_time if sim.closing_active else math.nan,
        completion_time=completion, mass=mass, failure_reason=reason,
        wall_time=wall_time, seed=None, steps=sim.step,
        max_penetration=sim.max_penetration, settled_terms=settled,
        launch_time=sim.launch_time, trace=trace, criterion=cfg.criterion,
        tug=None if sim.tug is None or sim.tug.outcome is None else sim.tug.outcome.to_dict())


def held_verdict(sim: CaptureSimulation) -> tuple[bool, str]:
    """Criterion 'held', for a capture the source's criterion calls a success: (whether the
    tug test held it at the required pull, why not).  The one home of this rule."""
    out = None if sim.tug is None else sim.tug.outcome
    if out is None:
        return False, f"{NOT_HELD}: the tug test did not run"
    if out.held:
        return True, ""
    return False, f"{NOT_HELD} under the required pull {out.peak_force:.4g} N: {out.reason}"


def source_verdict(r) -> tuple[bool, str]:
    """(success, failure reason) of a result by the source's criterion (an EpisodeResult,
    a Monte Carlo SampleResult or an EpisodeResult message: anything with success,
    failure_reason, criterion and tug or tug_tested).
    Under criterion 'held' the tug runs on the source's successes only, so a result whose
    tug was tested was the source's success; any other is judged as the source judged it."""
    reason = getattr(r, "failure_reason", "")
    if criterion_of(r) == "source":
        return bool(r.success), reason
    tested = getattr(r, "tug_tested", None)
    if tested is None:
        tested = getattr(r, "tug", None) is not None
    return (True, "") if tested else (bool(r.success), reason)


def run_episode(design: Design, sample: NoiseSample | None = None, config: SimConfig | None = None,
                record_trace: bool = True) -> EpisodeResult:
    """Simulate one capture of ``design`` under noise ``sample`` (None: nominal).

    Returns settled CQI and locked pairs 20 s after closing activation, success, closing
    time and completion time T (s), system mass m_a (kg), a failure reason where it failed,
    and (if ``record_trace``) the CQI / n_L series and node positions at the configured rates.
    """
    cfg = config or SimConfig()
    actions = actions_for(design, sample)
    world = world_for(design, sample, cfg.tumble)
    return run_actions(design, actions, world, cfg, record_trace,
                       seed=None if sample is None else sample.seed)


def run_actions(design: Design, actions: Actions, world: World, config: SimConfig,
                record_trace: bool = True, seed: int | None = None, observer=None) -> EpisodeResult:
    """Episode from explicit actions and world placement (the ROS path uses this); the
    sensor's noise is seeded with ``seed`` (``core.sensing``)."""
    sc = build_scenario(design, actions, world, config)
    sc.sensor_seed = seed_state(seed)
    sim = CaptureSimulation(sc)
    res = run_simulation(sim, record_trace=record_trace, observer=observer)
    res.seed = seed
    return res
