"""Fidelities: the named ways of simulating an episode of a configuration, and the one
home of what each changes.

``reference``: the configuration as given, unchanged bit for bit (every published number,
every validation).  ``exploration``: the same configuration with the implicit method's
step at 2 ms instead of 1 ms and 8 solver sweeps instead of 4, and the early call (a
clear success read at half the settle time ends the episode; config.py), at 0.39-0.61 of
the reference's CPU time (0.61-0.82 without the call).  On the ten Case designs and the
four reference designs of docs/studies/fidelity.md the 2 ms step's P*_s is within the
smaller 95 % half-width of the reference's (N = 100, common random numbers) and mean T
within 0.031 %; with the early call added, so is it on six of them held out from the
call's choice (base seed 1).  Its first form,
2 ms with 4 sweeps (docs/studies/step.md), lost 11 points of P*_s in Case 2's fast corner:
the closed net, whipping about the stage, gained energy there and was thrown off.  The
method's energy invariant is not checked at 2 ms, so exploration is not the default and no
claim rests on it: the optimiser may search with it, and races and validates at
``reference`` (docs/optimizer.md).

With the tug test on (``criterion: held`` or ``--tug``) exploration leaves the early call
off: the test starts from the state at the end of the settle time, and a capture called
early would never be pulled.  Its 2 ms step under the tug is measured in
docs/studies/tug-checks.md.

Exploration is defined only relative to the configuration those studies measured: the
implicit method (``integrator: implicit``) at the reference step (``dt: 0``,
``implicit_dt: 0.001`` s) and sweeps (``implicit_iterations: 4``); another is refused
(ConfigError naming the field) rather than scaled, since no study measured it.
"""
from __future__ import annotations

from .config import ConfigError, SimConfig

__all__ = ["FIDELITIES", "REFERENCE", "EXPLORATION", "FIDELITY_CHANGES",
           "FIDELITY_REQUIRES", "FidelityError", "check_fidelity", "at_fidelity",
           "fidelity_text"]

REFERENCE = "reference"
EXPLORATION = "exploration"
#: fidelity -> the SimConfig fields it sets (s for the steps); source of exploration's
#: 2 ms, 8 sweeps and early call: docs/studies/fidelity.md
FIDELITY_CHANGES: dict[str, dict] = {
    REFERENCE: {},
    EXPLORATION: {"implicit_dt": 2e-3, "implicit_iterations": 8, "early_call": True},
}
#: fidelity -> the SimConfig field values it needs in the configuration it is applied to
#: (the cells docs/studies/fidelity.md compared with: the implicit method at its 1 ms step
#: and 4 sweeps, read at the settle time)
FIDELITY_REQUIRES: dict[str, dict] = {
    REFERENCE: {},
    EXPLORATION: {"integrator": "implicit", "dt": 0.0, "implicit_dt": 1e-3,
                  "implicit_iterations": 4, "early_call": False},
}
#: the fidelity names, the reference first
FIDELITIES: tuple[str, ...] = tuple(FIDELITY_CHANGES)


class FidelityError(ConfigError):
    """A fidelity name that is not one of :data:`FIDELITIES`, or a configuration that
    the fidelity cannot be applied to (message names the field and what is allowed)."""


def check_fidelity(name, field: str = "fidelity") -> str:
    """``name`` if it is one of :data:`FIDELITIES`, else FidelityError naming ``field``
    (e.g. '--fidelity') and the allowed values."""
    if not isinstance(name, str) or name not in FIDELITY_CHANGES:
        raise FidelityError(f"{field}: got {name!r}; must be one of "
                            f"{', '.join(repr(f) for f in FIDELITIES)}")
    return name


def at_fidelity(config: SimConfig, fidelity: str, field: str = "fidelity") -> SimConfig:
    """``config`` simulated at ``fidelity``: ``reference`` returns ``config`` itself;
    ``exploration`` a copy with :data:`FIDELITY_CHANGES` applied (implicit step 2 ms, 8
    sweeps, the early call).
    FidelityError when the name is unknown or ``config`` lacks a field value
    :data:`FIDELITY_REQUIRES` names (``field``: how the caller names the fidelity)."""
    check_fidelity(fidelity, field)
    changes = _changes_for(fidelity, config)
    if not changes:
        return config
    for name, want in FIDELITY_REQUIRES[fidelity].items():
        got = getattr(config, name)
        if got != want:
            raise FidelityError(
                f"{field} {fidelity!r}: config field '{name}' is {got!r}; the {fidelity} "
                f"fidelity sets {_changes_text(changes)} and needs {name} = {want!r} "
                f"(docs/studies/fidelity.md measured it against the implicit method at 1 ms "
                f"and 4 sweeps, read at the settle time); "
                f"leave '{name}' at {want!r} or use {field} {REFERENCE!r}")
    try:
        return config.replace(**changes)
    except ConfigError as exc:               # e.g. a metric_rate the 2 ms step does not divide
        raise FidelityError(f"{field} {fidelity!r}: {exc}") from None


def fidelity_text(fidelity: str, config: SimConfig | None = None) -> str:
    """The fidelity in words, e.g. 'exploration (implicit_dt = 0.002 s, implicit_iterations
    = 8)'; for ``config`` when given (the tug test on: without the early call)."""
    changes = _changes_for(check_fidelity(fidelity), config)
    return fidelity if not changes else f"{fidelity} ({_changes_text(changes)})"


def _changes_for(fidelity: str, config: SimConfig | None) -> dict:
    """What ``fidelity`` changes in ``config``: :data:`FIDELITY_CHANGES`, without the early
    call when the tug test is on (the module's docstring)."""
    changes = FIDELITY_CHANGES[fidelity]
    if config is not None and config.tug.enabled:
        changes = {k: v for k, v in changes.items() if k != "early_call"}
    return changes


def _changes_text(changes: dict) -> str:
    return ", ".join(f"{k} = {v:g} s" if k.endswith("dt") else
                     f"{k} = {str(v).lower()}" if isinstance(v, bool) else f"{k} = {v!r}"
                     for k, v in changes.items())
