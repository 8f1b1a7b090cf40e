"""The tug test (docs/model.md §17): does the closed net hold its target when the chaser
pulls?  An optional phase after the settle time, off by default (every result without it
is unchanged bit for bit).

When the settle time has passed and the capture's verdict by the CQI has been read, the
chaser thrusts away from the target's centre of mass with ``peak_tension`` (``kernel.tug``).
First it takes up the slack of the tether and the net, never moving away from the target
faster than ``creep_speed``, until the tether carries half the thrust (at most
``take_up_time``); then the thrust is held for ``hold_time``, whatever the speed.  The
tether, the net and its contact with the target carry it; nothing else is added.

The capture **holds** when, at the end of the test, all three are true:

- *the target follows*: it is still inside the net: the net's centre of mass is within the
  target's bounding radius of the target's centre of mass (a net that let go is pulled
  away with the chaser, tens of metres off);
- *the net stays closed*: at least ``success_locked_pairs`` drawstring pairs (the count
  the source's criterion asks for at the settle time) are closer than twice the lock
  distance (a pair latched at the lock distance hovers about it; an open pair is a third
  of the net's side apart, 5-7 m for the reference designs);
- *the net stays on*: of the net's mass that lay within one mesh side of the target's
  surface when the test began, at most ``max_slid_share`` has moved farther than that.

Reported with each verdict: the peak tether tension (N, any step), the largest slip (m:
the largest growth of a net node's distance to the target's surface), the net's offset
(m), the share slid off, the closed pairs, and the follow ratio: over the hold's second
half, the target's displacement along the pull over that of the whole system's centre of
mass (1: it moves with the system).  The ratio is reported, not judged: at 100-400 N it
spreads over 0.14-1.01 for held and lost captures alike (the slack of the tether and the
net still being taken up, or the kick a net gives as it slides off; docs/model.md §17).  Units: SI (m, s, kg, N, Pa).
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from .checks import check_numbers, declared_floats
from .kernel.data import E_TUG_STEP, E_TUG_TAUT

__all__ = ["TugConfig", "TugError", "TugOutcome", "TugTest", "breaking_load", "outcome_text",
           "pull_ladder", "required_pull", "tug_params"]

#: (low, high, words) of the numeric settings
_LIMITS = {
    "peak_tension": (0.0, 1e7, "a force in [0, 1e7] N (0: tow_acceleration times the "
                                "target's mass)"),
    "tow_acceleration": (1e-4, 10.0, "an acceleration in [1e-4, 10] m/s^2"),
    "tether_strength": (1e8, 1e10, "a tensile strength in [1e8, 1e10] Pa"),
    "hold_time": (0.1, 600.0, "a time in [0.1, 600] s"),
    "creep_speed": (0.001, 10.0, "a speed in [0.001, 10] m/s"),
    "take_up_time": (0.1, 3600.0, "a time in [0.1, 3600] s"),
    "max_slid_share": (0.0, 1.0, "a share in [0, 1]"),
    "ladder_levels": (0, 20, "a whole number of levels in [0, 20]"),
    "ladder_ratio": (1.05, 10.0, "a ratio in [1.05, 10]"),
}


class TugError(ValueError):
    """A tug setting is outside its allowed range (message names the field)."""


@dataclass(frozen=True)
class TugConfig:
    """The tug test's settings (docs/model.md §17 gives each one's source).

    enabled: run the test after the settle time (default off; ``criterion: held`` turns it
    on).  The required pull (N): ``peak_tension`` when given (> 0, a thrust given
    directly: ``--tug N``), else ``tow_acceleration`` (m/s^2, default 0.05: a stated
    requirement, not a sourced one, about 180 m/s of delta-v per hour of towing) times the
    episode's target mass; at most the main tether's breaking load.  tether_strength (Pa):
    the tether's tensile strength, default 3.3e9 Pa, the lower end of 3.3-3.9 GPa for
    Dyneema SK75/SK78 fibre (DSM fact sheet CIS YA100, 2010; a braided rope keeps only part
    of its fibre's strength, so this bounds the rope's strength from above); hold_time (s),
    creep_speed (m/s: the chaser's largest speed away from the target while it takes up
    the slack), take_up_time (s: the longest that may take): the test's protocol;
    max_slid_share: the verdict's threshold; ladder_levels, ladder_ratio: after a capture
    held the required pull, the pull is raised by ladder_ratio and held hold_time again, up
    to ladder_levels times, below the breaking load, until it is lost: the largest pull
    held is the capture's holding force (the protocol's choices, not physical constants;
    docs/model.md §17)."""

    enabled: bool = False
    peak_tension: float = 0.0
    tow_acceleration: float = 0.05
    tether_strength: float = 3.3e9
    hold_time: float = 10.0
    creep_speed: float = 0.2
    take_up_time: float = 60.0
    max_slid_share: float = 0.5
    ladder_levels: int = 3
    ladder_ratio: float = 2.0

    def __post_init__(self):
        declared_floats(self)
        if not isinstance(self.enabled, bool):
            raise TugError(f"tug field 'enabled': got {self.enabled!r}; must be true or false")
        check_numbers("tug", self, _LIMITS, TugError)
        if int(self.ladder_levels) != self.ladder_levels:
            raise TugError(f"tug field 'ladder_levels': got {self.ladder_levels!r}; must be "
                           f"{_LIMITS['ladder_levels'][2]}")
        object.__setattr__(self, "ladder_levels", int(self.ladder_levels))

    def to_dict(self) -> dict:
        return asdict(self)


def breaking_load(tug: TugConfig, tether_radius: float) -> float:
    """The main tether's breaking load (N): tether_strength times its cross-section
    pi r^2 (``tether_radius`` in m)."""
    return tug.tether_strength * math.pi * tether_radius * tether_radius


def required_pull(tug: TugConfig, target_mass: float, tether_radius: float) -> float:
    """The pull (N) a capture must hold: ``peak_tension`` when given, else
    ``tow_acceleration`` times ``target_mass`` (kg); TugError naming the field that set it
    when it exceeds the main tether's breaking load (a pull the tether cannot carry)."""
    limit = breaking_load(tug, tether_radius)
    where = (f"tether_strength {tug.tether_strength:g} Pa times pi r^2, r = "
             f"{tether_radius:g} m")
    if tug.peak_tension > 0:
        if tug.peak_tension > limit:
            raise TugError(f"tug field 'peak_tension': got {tug.peak_tension:g} N; must be at "
                           f"most the main tether's breaking load {limit:.4g} N ({where})")
        return float(tug.peak_tension)
    pull = tug.tow_acceleration * target_mass
    if pull > limit:
        raise TugError(f"tug field 'tow_acceleration': got {tug.tow_acceleration:g} m/s^2, a "
                       f"pull of {pull:.4g} N on the {target_mass:g} kg target; must be at most "
                       f"{limit / target_mass:.4g} m/s^2, the main tether's breaking load "
                       f"{limit:.4g} N ({where}) over the target's mass")
    return float(pull)


def pull_ladder(tug: TugConfig, pull: float, tether_radius: float) -> tuple[float, ...]:
    """The pulls (N) of the holding-force ladder above the required ``pull``: pull times
    ladder_ratio^k, k = 1..ladder_levels, those at most the breaking load."""
    limit = breaking_load(tug, tether_radius)
    levels = []
    force = pull
    for _ in range(tug.ladder_levels):
        force = force * tug.ladder_ratio
        if force > limit:
            break
        levels.append(float(force))
    return tuple(levels)


def tug_params(tug: TugConfig) -> dict:
    """The kernel's tug parameter (``kernel.Params`` tug_creep, m/s); zero when the test
    is off.  The thrust is per lane (``Data.tug_force``), set by :class:`TugTest`."""
    return {"tug_creep": float(tug.creep_speed) if tug.enabled else 0.0}


@dataclass
class TugOutcome:
    """The test's verdict and its measures: held (bool), reason ('' when held), peak
    tether tension (N), largest slip (m), the net's offset (m, its centre of mass from the
    target's at the end), follow ratio, share slid off, closed pairs, the peak thrust (N:
    the required pull), the time the slack took to take up (s; NaN: it never was) and the
    test's duration (s), all at the required pull; then the holding force (N: the largest
    pull held, the required pull or a level of the ladder above it; 0 when the required
    pull was not held) and the ladder's levels above the required pull, each a mapping of
    its pull (N), held, reason and peak tether tension (N) (``ladder``: the levels tested,
    up to the first lost)."""

    held: bool
    reason: str
    peak_tension: float
    largest_slip: float
    net_offset: float
    follow_ratio: float
    slid_share: float
    closed_pairs: int
    peak_force: float
    take_up_time: float
    duration: float
    holding_force: float = 0.0
    ladder: list = field(default_factory=list)

    def to_dict(self) -> dict:
        d = asdict(self)
        for k, v in d.items():
            if isinstance(v, float) and not math.isfinite(v):
                d[k] = None
        return d


def outcome_text(tug: dict) -> str:
    """A verdict (:meth:`TugOutcome.to_dict`) in one line, e.g. "HELD under 400 N (peak
    tether tension 3305 N, ...)"; the reason follows when it was lost."""
    def num(v, unit, digits):
        return "n/a" if v is None or v != v else f"{v:.{digits}f}{unit}"
    text = (f"{'HELD' if tug['held'] else 'LOST'} under {tug['peak_force']:g} N  (peak tether "
            f"tension {num(tug['peak_tension'], ' N', 0)}, largest slip "
            f"{num(tug['largest_slip'], ' m', 2)}, net offset {num(tug['net_offset'], ' m', 2)}, "
            f"follow ratio {num(tug['follow_ratio'], '', 2)}, slid off "
            f"{num(tug['slid_share'] * 100, ' %', 1)}, closed pairs {tug['closed_pairs']})")
    text += f": {tug['reason']}" if tug["reason"] else ""
    ladder = tug.get("ladder") or []
    if tug["held"] and ladder:
        steps = ", ".join(f"{lv['force']:g} N {'held' if lv['held'] else 'lost'}"
                          for lv in ladder)
        text += f"; holding force {tug.get('holding_force', 0.0):g} N (ladder: {steps})"
    return text


class TugTest:
    """The test's phases for one episode (``episode.CaptureSimulation``): the host starts it
    at the end of the settle time (:meth:`start`); taking up the slack ends when the kernel
    marks the tether taut; the hold's first half follows, then its second (the follow
    ratio's window, :meth:`start_window`); the host judges it at its end (:meth:`judge`),
    reading the episode's arrays: the verdict at the required pull.  A capture that held
    then climbs the ladder (:func:`pull_ladder`): each level holds its pull for hold_time
    and is judged by the same measures, until one is lost or none is left; the largest pull
    held is the holding force.  Everything up to the verdict at the required pull is the
    single-level test's, step for step.  The kernel applies the thrust the test sets for
    the lane (``Data.tug_force``) and keeps the peak tension."""

    def __init__(self, sim, tug: TugConfig):
        self.sim = sim
        self.cfg = tug
        #: the required pull (N) and the ladder's pulls above it, computed and checked
        #: against the breaking load when the scenario was built (:func:`required_pull`)
        self.force = float(sim.s.tug_pull)
        self.ladder = tuple(sim.s.tug_ladder)
        #: the ladder's current level (index into ``ladder``) and the step it began
        self.level: int | None = None
        self.level_start_step: int | None = None
        dt = sim.dt
        self.hold_steps = max(1, int(round(tug.hold_time / dt)))
        self.take_up_steps = max(1, int(round(tug.take_up_time / dt)))
        self.start_step: int | None = None
        self.hold_start_step: int | None = None
        #: the follow ratio is measured over the hold's second half
        self.window_steps = max(1, self.hold_steps // 2)
        self.window_start_step: int | None = None
        self.outcome: TugOutcome | None = None
        self._near0 = None
        self._dist0 = None
        self._system_hold0 = None
        self._target_hold0 = None
        self._pull = None
        self.start_momentum = None
        self.start_direction = None

    @property
    def started(self) -> bool:
        return self.start_step is not None

    @property
    def taut_step(self) -> int | None:
        """The first step in which the tether carried tension (None: not yet)."""
        t = int(self.sim.s.events[E_TUG_TAUT])
        return None if t < 0 else t

    def end_step(self) -> int:
        """The step at which the current phase ends: taking up the slack (at most
        take_up_time; it ends at the first look after the tether went taut), the hold's
        first half, its second half (the follow ratio's window)."""
        if self.level is not None:
            return self.level_start_step + self.hold_steps
        if self.hold_start_step is None:
            return (self.start_step + self.take_up_steps if self.taut_step is None
                    else self.sim.step)
        if self.window_start_step is None:
            return self.hold_start_step + self.hold_steps - self.window_steps
        return self.window_start_step + self.window_steps

    # -- what the host calls -------------------------------------------------------------
    def start(self) -> None:
        """Start the test at the simulation's current step."""
        sim = self.sim
        self.start_step = sim.step
        sim.s.events[E_TUG_STEP] = sim.step
        sim.data.tug_peak[sim.s.lane] = 0.0
        sim.data.tug_force[sim.s.lane] = self.force
        #: the system's linear momentum (kg m/s) and the pull's direction when it began
        self.start_momentum = sim.linear_momentum().copy()
        self.start_direction = self._pull_direction()
        self._dist0 = self._surface_distances()
        self._near0 = self._dist0 <= self._mesh_side()

    def start_hold(self) -> None:
        """The slack is taken up: the hold starts here."""
        self.hold_start_step = self.sim.step

    def start_window(self) -> None:
        """The hold's second half starts: the follow ratio is measured from here."""
        self.window_start_step = self.sim.step
        self._system_hold0 = self._system_com()
        self._target_hold0 = self.sim.s.target_body.pos.copy()
        self._pull = self._pull_direction()

    def advance_phase(self) -> bool:
        """At the end of a phase: begin the next (True: the test goes on) or judge the test
        (False: it has ended)."""
        if self.level is not None:
            return self._judge_level()
        if self.outcome is not None:
            return False
        if self.hold_start_step is None:
            if self.taut_step is None:
                self.judge(f"the target did not follow: the tether never carried half the "
                           f"thrust within take_up_time {self.cfg.take_up_time:g} s (creeping "
                           f"away at {self.cfg.creep_speed:g} m/s)", measured=True)
                return False
            self.start_hold()
            return True
        if self.window_start_step is None:
            self.start_window()
            return True
        self.judge()
        return self._next_level()

    def end_early(self, reason: str) -> None:
        """The simulation ended the test (e.g. diverged): the verdict at the required pull
        when it was not yet judged, else the ladder's current level is lost."""
        if self.outcome is None:
            self.judge(reason)
        elif self.level is not None:
            self._record_level(False, reason)
            self.level = None

    # -- the ladder ----------------------------------------------------------------------
    def _next_level(self) -> bool:
        """After a level held (or the required pull): raise the pull to the ladder's next
        level (True) or end the test (False: it was lost, or no level is left)."""
        out = self.outcome
        nxt = 0 if self.level is None else self.level + 1
        if not out.held or nxt >= len(self.ladder):
            self.level = None
            return False
        sim = self.sim
        self.level = nxt
        self.level_start_step = sim.step
        sim.data.tug_force[sim.s.lane] = self.ladder[nxt]
        sim.data.tug_peak[sim.s.lane] = 0.0
        return True

    def _judge_level(self) -> bool:
        """The end of a level: record its verdict; climb on (True) or stop (False)."""
        why, _ = self._verdict()
        self._record_level(not why, why)
        if why:
            self.level = None
            return False
        return self._next_level()

    def _record_level(self, held: bool, reason: str) -> None:
        sim = self.sim
        force = self.ladder[self.level]
        self.outcome.ladder.append({"force": float(force), "held": bool(held), "reason": reason,
                                    "peak_tension": float(sim.data.tug_peak[sim.s.lane])})
        if held:
            self.outcome.holding_force = float(force)

    def _verdict(self) -> tuple[str, dict]:
        """('' when held, else why not; the measures) at the simulation's current step."""
        sim = self.sim
        cfg = self.cfg
        dist = self._surface_distances()
        slip = dist - self._dist0
        largest_slip = float(max(0.0, float(slip.max())))
        mesh = self._mesh_side()
        masses = sim.net_masses
        near_mass = float(masses[self._near0].sum())
        slid = self._near0 & (dist > mesh)
        slid_share = float(masses[slid].sum()) / near_mass if near_mass > 0 else 1.0
        closed = self._closed_pairs()
        offset = float(np.linalg.norm(sim.net_centre_of_mass() - sim.s.target_body.pos))
        reach = float(sim.s.target.bounding_radius)
        why = ""
        if not offset <= reach:
            why = (f"the target did not follow: the net's centre of mass ended {offset:.3g} m "
                   f"from the target's (at most its bounding radius {reach:.3g} m)")
        if not why and closed < sim.cfg.success_locked_pairs:
            why = (f"the net opened: {closed} drawstring pairs within twice the lock distance "
                   f"at the end (at least {sim.cfg.success_locked_pairs} needed)")
        if not why and slid_share > cfg.max_slid_share:
            why = (f"the net slid off: {slid_share:.1%} of the net's mass on the target left it "
                   f"(at most {cfg.max_slid_share:.0%})")
        return why, {"largest_slip": largest_slip, "slid_share": slid_share,
                     "closed_pairs": closed, "net_offset": offset}

    def judge(self, reason: str = "", measured: bool = False) -> TugOutcome:
        """The verdict at the required pull, at the simulation's current step (``reason``:
        why the test ended early, e.g. a divergence: then the net did not hold; with
        ``measured`` the reason stands only if the measures find nothing else)."""
        sim = self.sim
        measured_why, m = self._verdict()
        why = "" if measured else reason
        why = why or measured_why or reason
        follow = math.nan
        if self._pull is not None:
            moved_system = float((self._system_com() - self._system_hold0) @ self._pull)
            moved_target = float((sim.s.target_body.pos - self._target_hold0) @ self._pull)
            follow = moved_target / moved_system if moved_system > 0 else math.nan
        self.outcome = TugOutcome(
            held=not why, reason=why,
            peak_tension=float(sim.data.tug_peak[sim.s.lane]),
            largest_slip=m["largest_slip"], net_offset=m["net_offset"],
            follow_ratio=follow, slid_share=m["slid_share"], closed_pairs=m["closed_pairs"],
            peak_force=float(self.force),
            take_up_time=(math.nan if self.taut_step is None
                          else (self.taut_step - self.start_step) * sim.dt),
            duration=(sim.step - self.start_step) * sim.dt,
            holding_force=0.0 if why else float(self.force))
        return self.outcome

    # -- measures ------------------------------------------------------------------------
    def _pull_direction(self) -> np.ndarray:
        """The unit vector from the target's centre of mass to the chaser (the thrust's
        direction, as the kernel computes it)."""
        s = self.sim.s
        d = s.bodies.x[s.tether.winch] - s.target_body.pos
        return d / max(float(np.sqrt(d @ d)), 1e-12)

    def _system_com(self) -> np.ndarray:
        """The centre of mass (m) of every body with mass and the target (the bodies
        ``CaptureSimulation.linear_momentum`` counts)."""
        sim = self.sim
        b = sim.s.bodies
        dyn = sim.dynamic_bodies()
        m_t = sim.target_mass
        total = float(b.mass[dyn].sum()) + m_t
        return ((b.x[dyn] * b.mass[dyn, None]).sum(axis=0) + m_t * sim.s.target_body.pos) / total

    def _mesh_side(self) -> float:
        return float(self.sim.s.grid.rest)

    def _surface_distances(self) -> np.ndarray:
        """Signed distances (m) of the net's nodes to the target's surface, by the kernel's
        own query in the target's body frame."""
        from .kernel import quat_to_matrix
        s = self.sim.s
        tb = s.target_body
        R = quat_to_matrix(tb.quat)
        body = (s.bodies.x[s.net_nodes] - tb.pos) @ R + tb.com_offset
        d, _ = s.target.signed_distances(body)
        return np.asarray(d)

    def _closed_pairs(self) -> int:
        s = self.sim.s
        x = s.bodies.x
        p = s.drawstring.pairs
        gaps = np.sqrt(((x[p[:, 1]] - x[p[:, 0]]) ** 2).sum(axis=1))
        return int((gaps <= 2.0 * self.sim.cfg.lock_distance).sum())
