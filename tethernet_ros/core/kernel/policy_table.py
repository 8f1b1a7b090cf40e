"""The chaser's policies, one table (docs/model.md §14 closing, §16 launch): for each, the
decision it takes (its role), who takes it, the settings it reads, the per-lane memory it
keeps and a line of what it does.  Every list of policies the project shows or checks is
read from here: the kernel's indices (``policy``, ``launch``), the configurations' allowed
kinds (``core.policies``, ``core.launch``), the command-line choices and help, the ROS
parameters' descriptions, the rule of which episodes run through ROS (``ros.loop``) and
the studies' cells.

A new policy is a row here, its rule (a numba function of ``(model, data, lane, ...)``
beside its role's others, ``policy.decide`` or ``launch.decide_launch``, with the one
line of dispatch that calls it; the kernel's dispatch stays an if-chain on the index,
since numba caches no generated dispatcher), the settings it reads in its role's
configuration, and its docs.

Deciders: 'kernel' (a rule of the project's decides, inside the kernel or, in a ROS
loop, its copy in the actuator node); 'controller' (a node outside the kernel decides: a
user's, or the loop's); 'none' (nothing to decide: the immediate launch fires at once).
"""
from __future__ import annotations

from collections import namedtuple

#: name; role 'closing' or 'launch'; decider 'kernel', 'controller' or 'none'; settings:
#: the fields of its role's configuration it reads (``PolicyConfig``, ``LaunchConfig``);
#: memory: what it keeps per lane between decisions, and where; summary: what it does
PolicySpec = namedtuple("PolicySpec", "name role decider settings memory summary")

KERNEL, CONTROLLER, NONE = "kernel", "controller", "none"

POLICY_TABLE = (
    PolicySpec("threshold", "closing", KERNEL, (), (),
               "close when the sensed z_rel reaches the closing displacement (the source's "
               "rule, the default)"),
    PolicySpec("adaptive", "closing", KERNEL, ("closing_time", "apex"),
               ("data.policy.prev_zrel", "data.policy.has_prev"),
               "the threshold measured from the stage's far side over the next closing_time, "
               "and at the net's apex"),
    PolicySpec("external", "closing", CONTROLLER, (), (),
               "a controller outside the kernel closes (a ROS node: --via ros --controller)"),
    PolicySpec("immediate", "launch", NONE, (), (),
               "fire at once (the default)"),
    PolicySpec("predictive", "launch", KERNEL, ("max_wait", "max_tilt_deg", "confirm_time"),
               ("events[E_FAVOURABLE_SINCE]",),
               "wait until the tumbling target is predicted to lie across the line of sight "
               "while the net wraps it"),
    PolicySpec("external", "launch", CONTROLLER, ("max_wait",), (),
               "a controller outside the kernel fires (a ROS node)"),
)

ROLES = ("closing", "launch")


def policies(role: str, decider: str | None = None) -> tuple[str, ...]:
    """The names of ``role``'s policies in index order (those of one ``decider`` only,
    if given)."""
    if role not in ROLES:
        raise ValueError(f"role {role!r}: must be one of {', '.join(ROLES)}")
    return tuple(p.name for p in POLICY_TABLE
                 if p.role == role and (decider is None or p.decider == decider))


def policy_index(role: str, name: str) -> int:
    """The kernel's index of ``role``'s policy ``name`` (its place in :func:`policies`)."""
    return policies(role).index(name)


def spec(role: str, name: str) -> PolicySpec:
    """The row of ``role``'s policy ``name``."""
    for p in POLICY_TABLE:
        if p.role == role and p.name == name:
            return p
    raise KeyError(f"no {role} policy {name!r}; one of {', '.join(policies(role))}")


def controller_policy(role: str) -> str:
    """The name of ``role``'s policy that leaves the decision to a controller outside the
    kernel (one per role)."""
    (name,) = policies(role, CONTROLLER)
    return name


def selectable(role: str) -> tuple[str, ...]:
    """``role``'s policies a flag can choose by name: all but the controller's (that one
    needs a controller node, --via ros --controller)."""
    return tuple(n for n in policies(role) if spec(role, n).decider != CONTROLLER)


def choices_help(role: str) -> str:
    """The selectable policies of ``role`` in words, for a flag's help."""
    return "; ".join(f"{n}: {spec(role, n).summary}" for n in selectable(role))
