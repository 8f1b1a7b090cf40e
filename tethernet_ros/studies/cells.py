"""The cells of each study: a label and a full simulation configuration.

``models``: the default model, then each modelling choice of docs/model.md §10 switched
alone to what the source's text says (docs/model.md §1-5), then all of them together.
``convergence``: the default, the same with half the step and with twice the implicit
solver's sweeps.  ``agreement``: the default integrator against the other one, same model.
``trigger``: which point the closing trigger follows (docs/model.md §14): the net's
reference points and the planned target distance.  ``tumbling``: the target spinning at
each rate about each axis, under the threshold and the adaptive policy.  ``launch``: the
flat spins and a precessing one, the immediate against the predictive launch.
``targets``: the designs as they are on every catalogued debris target (docs/targets.md)
that is not a model of the Zenit-2 itself, at rest and under a flat spin.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from ..core.config import SimConfig
from ..core.kernel.policy_table import KERNEL, policies, selectable
from ..core.noise import NoiseModel


@dataclass(frozen=True)
class Cell:
    """One column of a study: ``label`` (short), ``what`` (its source or meaning), the
    configuration its episodes run with and the noise model they draw from."""

    label: str
    what: str
    config: SimConfig
    noise: NoiseModel = field(default_factory=NoiseModel)


#: Each choice of the default model with the value the source's text gives it instead:
#: (label, overrides, what the text says).  One home for the model study's choices.
TEXT_CHOICES: tuple[tuple[str, dict, str], ...] = (
    ("closing force text", {"closing_force_factor": 2.0 / 25.0},
     "F_c = 2 m_c L_n / 25 (text) instead of 2 m_c L_n / 1^2 (code)"),
    ("ratchet lock", {"lock_model": "ratchet"},
     "force on every pair, a locked pair held by a shortening joint (text as implemented) "
     "instead of a latch (code)"),
    ("ring at net corners", {"drawstring_corners": "net"},
     "drawstring through the net's corner nodes (text) instead of the corner masses (code)"),
    ("element damping", {"thread_damping": "element"},
     "c = 2 zeta sqrt(k m_eff) per thread (text) instead of 2 zeta k / omega_1 (code)"),
    ("friction 0.3", {"friction": 0.3, "static_friction_scale": 1.0},
     "Coulomb mu = 0.3 (text) instead of kinetic 0.152, static 0.19 (code)"),
    ("contact 1000 rad/s", {"contact_model": "frequency", "contact_damping_ratio": 0.3},
     "per-body contact frequency 1000 rad/s, damping 0.3 (text as implemented) instead of "
     "linearised Hertz / 10, damping 0.106 (code)"),
    ("spheres 2 / 5 cm", {"contact_radius": "fixed"},
     "contact spheres 2 cm (nodes) and 5 cm (corner masses) instead of density-sized (code)"),
    ("corner thread 1 mesh", {"corner_thread_meshes": 1.0},
     "corner thread one mesh side (text) instead of sqrt 2 (code)"),
    ("tether r_n", {"tether_radius": 0.0},
     "main tether of the net's thread radius (text) instead of 2 mm (code)"),
)


def _spec_text(base: SimConfig) -> SimConfig:
    """All of the text's choices, on the base configuration's numerical method."""
    keep = {f: getattr(base, f) for f in ("integrator", "implicit_dt", "implicit_iterations",
                                          "dt", "dt_safety", "horizon", "settle_time")}
    return SimConfig.preset("spec-text", **keep)


#: Choices the text does not make and the reference's code leaves open, measured beside
#: the text's: (label, overrides, what it means).
OPEN_CHOICES: tuple[tuple[str, dict, str], ...] = (
    ("inelastic impacts", {"implicit_impacts": "inelastic"},
     "new impacts without rebound, as a step longer than the contact's period gives by "
     "itself, instead of the contact law's restitution (0.73 at zeta 0.106): the reference's "
     "1 ms solver gave its contacts a restitution its code does not state"),
)


def model_cells(base: SimConfig) -> list[Cell]:
    """The model study: the base, each text choice alone, all of them ("spec-text"), and
    the open choices (implicit method only)."""
    cells = [Cell("default", "the default model (docs/model.md)", base)]
    for label, overrides, what in TEXT_CHOICES:
        cells.append(Cell(label, what, base.replace(**overrides)))
    cells.append(Cell("all text", "every choice as the text gives it (preset spec-text)",
                      _spec_text(base)))
    if base.integrator == "implicit":
        for label, overrides, what in OPEN_CHOICES:
            cells.append(Cell(label, what, base.replace(**overrides)))
    cells.append(Cell("orientation about y", "the target's orientation noise about y (across the "
                      "line of sight) instead of z, the alternative of docs/model.md §1", base,
                      NoiseModel(orientation_axis="y")))
    return cells


def convergence_cells(base: SimConfig) -> list[Cell]:
    """The default, the same with half the step (implicit: implicit_dt / 2; explicit:
    dt_safety / 2) and, for the implicit method, with twice the solver's sweeps."""
    if base.integrator == "implicit":
        cells = [Cell("default", f"the default: implicit, {base.implicit_dt:g} s, "
                      f"{base.implicit_iterations} sweeps", base),
                 Cell("half step", f"implicit step {base.implicit_dt / 2:g} s",
                      base.replace(implicit_dt=base.implicit_dt / 2)),
                 Cell("double sweeps", f"{2 * base.implicit_iterations} sweeps per step",
                      base.replace(implicit_iterations=2 * base.implicit_iterations))]
    else:
        cells = [Cell("default", f"the default: explicit, step fraction {base.dt_safety:g}", base),
                 Cell("half step", f"explicit step fraction {base.dt_safety / 2:g}",
                      base.replace(dt_safety=base.dt_safety / 2))]
    return cells


def agreement_cells(base: SimConfig) -> list[Cell]:
    """The default integrator and the other one on the same model."""
    other = "explicit" if base.integrator == "implicit" else "implicit"
    return [Cell(base.integrator, f"the default model, {base.integrator} method", base),
            Cell(other, f"the same model, {other} method", base.replace(integrator=other))]


def trigger_cells(base: SimConfig) -> list[Cell]:
    """The source's trigger (the net's centre of mass against the sensed target), each
    other net reference point, and the planned target distance instead of the sensed one."""
    from ..core.sensing import SensingConfig

    s = base.sensing
    what = {"centre": "the net's centre node", "corners": "the centroid of the four corner masses",
            "com_corners": "the centre of mass of the grid nodes and the corner masses"}
    cells = [Cell("net CoM", "the source's trigger: the centre of mass of the grid nodes "
                  "against the sensed target", base)]
    for point, words in what.items():
        cells.append(Cell(point.replace("_", " + "), f"{words} against the sensed target",
                          base.replace(sensing=SensingConfig(**{**vars(s), "net_point": point}))))
    cells.append(Cell("planned d_L", "the net's centre of mass against the planned target "
                      "distance d_L (which the distance noise makes wrong)",
                      base.replace(sensing=SensingConfig(**{**vars(s),
                                                            "target_position": "planned"}))))
    return cells


#: the tumbling study's rates (deg/s) and axes (core.tumble.AXES)
TUMBLE_RATES = (0.5, 1.0, 2.0, 4.0, 8.0)
TUMBLE_AXES = ("flat", "los", "long")


def tumbling_cells(base: SimConfig) -> list[Cell]:
    """At rest, then each rate about each axis (random phase, the noise model's), each
    under the threshold and the adaptive policy: label '<axis> <rate> <policy>'."""
    from ..core.policies import PolicyConfig
    from ..core.tumble import TumbleConfig

    cells = []
    for kind in CLOSING_POLICIES:
        pol = PolicyConfig(**{**vars(base.policy), "kind": kind})
        cells.append(Cell(f"rest {kind}", f"target at rest, {kind} policy",
                          base.replace(policy=pol)))
    for axis in TUMBLE_AXES:
        for rate in TUMBLE_RATES:
            for kind in CLOSING_POLICIES:
                pol = PolicyConfig(**{**vars(base.policy), "kind": kind})
                cells.append(Cell(f"{axis} {rate:g} {kind}",
                                  f"{rate:g} deg/s about the {axis} axis, {kind} policy",
                                  base.replace(tumble=TumbleConfig(rate_deg_s=rate, axis=axis),
                                               policy=pol)))
    return cells


#: the launch study's sensing, stated (docs/studies/launch.md): 50 Hz, 60 ms latency, 2 cm
#: on positions, 2 deg on the attitude and 0.1 deg/s on the angular velocity, per axis
LAUNCH_SENSING = {"rate_hz": 50.0, "latency": 0.06, "sigma_position": 0.02,
                  "sigma_attitude_deg": 2.0, "sigma_rate_deg_s": 0.1}
#: its precessing case: a spin about a body axis between the long and the flat one
#: (63 deg from the long axis), where the stage's long axis cones about its momentum
PRECESSING_AXIS = (0.5, 1.0, 0.0)
PRECESSING_RATES = (2.0, 8.0)
#: the policies the studies compare: the closing policies of the project's, and the launch
#: policies a flag can choose (core/kernel/policy_table.py)
CLOSING_POLICIES = policies("closing", KERNEL)
LAUNCHES = selectable("launch")


def launch_cells(base: SimConfig) -> list[Cell]:
    """Each flat-spin rate, then the precessing spin, under each closing policy, with the
    immediate and the predictive launch side by side, all with LAUNCH_SENSING's noise
    (unless the base configuration has noise of its own): label '<axis> <rate> <closing>
    <launch>'."""
    from ..core.launch import LaunchConfig
    from ..core.policies import PolicyConfig
    from ..core.sensing import SensingConfig
    from ..core.tumble import TumbleConfig

    sensing = (SensingConfig(**{**vars(base.sensing), **LAUNCH_SENSING})
               if base.sensing.noiseless else base.sensing)
    # the rates at both ends and the middle first, so that a study stopped early has
    # measured the span (the report sorts them)
    order = sorted(TUMBLE_RATES, key=lambda r: (r not in (0.5, 2.0, 8.0), r))
    spins = [("flat", rate, "flat") for rate in order]
    spins += [("precessing", rate, PRECESSING_AXIS) for rate in PRECESSING_RATES]
    cells = []
    for name, rate, axis in spins:
        for kind in CLOSING_POLICIES:
            for launch in LAUNCHES:
                cfg = base.replace(tumble=TumbleConfig(rate_deg_s=rate, axis=axis),
                                   policy=PolicyConfig(**{**vars(base.policy), "kind": kind}),
                                   launch=LaunchConfig(**{**vars(base.launch), "kind": launch}),
                                   sensing=sensing)
                cells.append(Cell(f"{name} {rate:g} {kind} {launch}",
                                  f"{rate:g} deg/s about the {name} axis, {kind} closing, "
                                  f"{launch} launch", cfg))
    return cells


#: the targets study's spin: the flat one (about the axis of greatest inertia) at the rate
#: the tug and criterion studies use (docs/studies/tug.md)
TARGETS_SPIN = (2.0, "flat")


def targets_cells(base: SimConfig) -> list[Cell]:
    """The base configuration's target (the Zenit-2 by default) at rest and under
    TARGETS_SPIN, then each catalogue target other than the Zenit-2's own meshes (which
    docs/studies/mesh-agreement.md compares with the analytic stage) likewise: label
    '<target> rest' or '<target> flat 2'.  The designs are not scaled to the target: the
    table says how the designs chosen for the Zenit-2 do on other debris."""
    from ..core.shapes.catalogue import CATALOGUE
    from ..core.target import TargetConfig
    from ..core.tumble import TumbleConfig

    rate, axis = TARGETS_SPIN
    targets = [(base.target.name, base.target)]
    targets += [(name, TargetConfig(name=name)) for name in CATALOGUE
                if not name.startswith("zenit-2")]
    cells = []
    for name, target in targets:
        at_rest = base.replace(target=target, tumble=TumbleConfig())
        cells.append(Cell(f"{name} rest", f"{name}, at rest", at_rest))
        cells.append(Cell(f"{name} {axis} {rate:g}", f"{name}, {rate:g} deg/s about its "
                          f"{axis} axis (greatest inertia)",
                          at_rest.replace(tumble=TumbleConfig(rate_deg_s=rate, axis=axis))))
    return cells


STUDIES = {"launch": launch_cells, "models": model_cells, "convergence": convergence_cells,
           "agreement": agreement_cells, "trigger": trigger_cells, "tumbling": tumbling_cells,
           "targets": targets_cells}

