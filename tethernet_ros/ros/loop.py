"""The closing loop cut at its joints, as the nodes run it (no ROS import).

In a *lockstep* episode the policies run outside the kernel: the simulation's kernel has
the policies 'external' (it never closes or fires by itself).  Before the launch (a launch
policy other than 'immediate'), at every control step of the wait, the truth goes to the
sensor node and its measurement (``launched`` false) to a controller, whose
LaunchDecision fires the net or lets the target turn one step more.  After it, at every
control step
(every ``model.control.period`` integration steps, while closing is armed and not yet
active) the simulation node hands the true measurement to the sensor node, whose
measurement goes to a controller (the actuator's built-in policy, or a user's node),
whose decision comes back before the simulation advances; a decision to close is
commanded (``CaptureSimulation.command_closing``) at that very step.  That is the
kernel's own loop (``core/kernel/events.py``) step for step, with the same Sensor noise
and the same Policy memory, so the result is the in-kernel closed loop's bit for bit
(tests/test_core_sensing.py proves the loop in process, tests/test_ros_loop.py through
the nodes).

The episode's other rules are run_simulation's: a :class:`ControlledSimulation` only adds
the control steps to its advance, so run_simulation stops at the same clock steps, tests
for divergence and for the end there, and gives the result by the same rules.
"""
from __future__ import annotations

from dataclasses import replace

from ..core import kernel as kn
from ..core.kernel.policy_table import controller_policy
from ..core.config import SimConfig
from ..core.episode import CaptureSimulation
from ..core.launch import LaunchPolicy
from ..core.policies import Policy
from ..core.scenario import Actions, Scenario, World, build_scenario
from ..core.sensing import Sensor, seed_state, true_measurement
from .state import Setup

#: the policy kinds that leave the closing, and the launch, to a controller outside the
#: kernel (core/kernel/policy_table.py)
EXTERNAL = controller_policy("closing")
EXTERNAL_LAUNCH = controller_policy("launch")


def builtin_controller(node_name: str, kind: str) -> str:
    """What the actuator's built-in policy writes in a ClosingDecision's ``controller``."""
    return f"{node_name} (built-in {kind})"


def is_builtin_controller(controller: str) -> bool:
    """Whether a ClosingDecision's ``controller`` names the actuator's built-in policy."""
    return "(built-in " in controller


class LoopFailure(RuntimeError):
    """A lockstep episode's loop failed: the episode ends, its result failed with this
    message as the reason, and the capture node answers ABORTED with it."""


class ControllerTimeout(LoopFailure):
    """No decision came for a control step in time (the message is the failure reason,
    starting with names.CONTROLLER_TIMEOUT)."""


class ControllerConflict(LoopFailure):
    """Two publishers sent ClosingDecisions in one episode (the message is the failure
    reason, starting with names.TWO_CONTROLLERS)."""


def step_time_summary(times: list[tuple[float, float]]) -> str:
    """One line on a lockstep episode's control steps: ``times`` holds, per step, (s of
    wall time from the last step's decision to this one's, s of it spent waiting for the
    decision after the true measurement went out)."""
    import numpy as np

    a = np.array(times, dtype=float) * 1e3
    return (f"lockstep: {len(a)} control steps, wall time per step median {np.median(a[:, 0]):.2f} ms, "
            f"95th percentile {np.percentile(a[:, 0], 95):.2f} ms (waiting for the decision: "
            f"median {np.median(a[:, 1]):.2f} ms, 95th percentile {np.percentile(a[:, 1], 95):.2f} ms)")


def in_lockstep(asked: bool, config: SimConfig) -> bool:
    """The one rule of when an episode's policies run through ROS: when it was asked for
    (``lockstep``, a controller node), or when the configuration's closing or launch
    policy is 'external' (a controller outside the kernel decides, whatever was asked)."""
    return bool(asked) or config.policy.kind == EXTERNAL or config.launch.kind == EXTERNAL_LAUNCH


def runs_in_lockstep(setup: Setup) -> bool:
    """Whether an episode (its setup) runs in lockstep (:func:`in_lockstep`)."""
    return in_lockstep(setup.lockstep, setup.config)


def kernel_config(config: SimConfig) -> SimConfig:
    """The simulation's configuration of a lockstep episode: the same, with the kernel's
    closing policy 'external', and its launch policy too unless the launch is immediate
    (their other settings unchanged): every decision is taken through ROS."""
    out = config
    if out.policy.kind != EXTERNAL:
        out = out.replace(policy=replace(out.policy, kind=EXTERNAL))
    if out.launch.built_in:
        out = out.replace(launch=replace(out.launch, kind=EXTERNAL_LAUNCH))
    return out


def episode_scenario(setup: Setup, actions: Actions, world: World,
                     config: SimConfig | None = None) -> Scenario:
    """The episode's scenario from its setup and the actuator's commands, its sensor noise
    seeded with the episode's seed as ``run_episode`` seeds it (0 when nominal)."""
    sc = build_scenario(setup.design, actions, world, setup.config if config is None else config)
    sc.sensor_seed = seed_state(setup.seed)
    return sc


def episode_sensor(setup: Setup, scenario: Scenario) -> Sensor:
    """The episode's sensor outside the kernel (the sensor node's)."""
    return Sensor(scenario.control, seed_state(setup.seed))


def episode_launch_policy(setup: Setup, scenario: Scenario) -> LaunchPolicy | None:
    """The episode's built-in launch policy outside the kernel (the actuator node's);
    None when the launch is immediate (nothing to decide) or 'external' (a user's
    controller decides).  ``scenario`` must be built with the episode's own
    configuration (not :func:`kernel_config`'s)."""
    if not setup.config.launch.built_in:
        return None
    return LaunchPolicy(scenario.launch)


def episode_policy(setup: Setup, scenario: Scenario) -> Policy | None:
    """The episode's built-in policy outside the kernel (the actuator node's): the kind of
    its configuration, for its commanded closing displacement; None for 'external' (no
    built-in policy: a user's controller decides).  ``scenario`` must be built with the
    episode's own configuration (not :func:`kernel_config`'s)."""
    if setup.config.policy.kind == EXTERNAL:
        return None
    return Policy(scenario.kernel()[0], scenario.close_threshold)


def control_step_due(sim: CaptureSimulation, period: int) -> bool:
    """Whether the kernel would sense and decide after the current step: a control step
    of the mission's clock while closing is armed and not yet active
    (``closing_events``)."""
    ev = sim.s.events
    return (sim.mission_step % period == 0 and ev[kn.E_CLOSING_ARMED] == 1
            and ev[kn.E_CLOSING_ACTIVE] == 0)


def truth_of(sim: CaptureSimulation):
    """The true measurement of the simulation now (``core.sensing.true_measurement``)."""
    return true_measurement(sim.model, sim.data, sim.s.lane)


class ControlledSimulation(CaptureSimulation):
    """A CaptureSimulation whose decisions are taken outside the kernel (a lockstep
    episode's; the kernel's policies 'external'): ``advance`` stops at every control step
    where the kernel would decide closing (:func:`control_step_due`), asks
    ``controller(self)``, and commands closing at that step if it says so;
    :meth:`wait_for_launch` asks it at every control step of the wait before the launch
    (``self.launched`` false), and fires when it says so.  ``run_simulation`` after
    :meth:`wait_for_launch` is the in-kernel closed loop, bit for bit.  Without a
    controller it is a CaptureSimulation."""

    def __init__(self, scenario: Scenario, controller=None):
        super().__init__(scenario)
        self.controller = controller
        self.period = int(self.model.control.period)

    def wait_for_launch(self) -> None:
        """The wait before the launch, step by step as the kernel's (``kernel.launch``):
        at a control step the kernel's sensor measures and the controller decides; the
        net is fired when it says so, or at max_wait."""
        from ..core.kernel.launch import wait_step

        if self.launched:
            return
        if self.controller is None:
            raise RuntimeError("the launch policy 'external' needs a controller")
        while True:
            r = wait_step(self.model, self.data, self.scratch, self.s.lane)
            if r > 0:
                return
            if r < 0:
                if self.controller(self):
                    self.fire()
                    return
                self.hold()

    def advance(self, n_steps: int) -> None:
        if self.controller is None:
            super().advance(n_steps)
            return
        target = self.step + n_steps
        while self.step < target:
            nxt = target if self.closing_active else \
                min(target, (self.step // self.period + 1) * self.period)
            super().advance(nxt - self.step)
            if control_step_due(self, self.period) and self.controller(self):
                self.command_closing()
