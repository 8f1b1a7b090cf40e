"""The settings of an optimisation run: their defaults, their allowed ranges and their
checks, in one place.

:class:`RunSettings` is what a run is asked to do (budget, sample sizes, seeds, sampling,
validation, selection); it checks every field when built and raises :class:`SettingError`
(a :class:`RunError`) naming the field and its allowed range.  A run directory records the
settings in run.json (:meth:`RunSettings.record`); a resumed run must be asked for the same
ones, except the :data:`MUTABLE` ones.

The fields of :data:`NEW_RUN_DEFAULTS` (``validation_candidates``, ``validation_rule``,
``validation_stop``, ``racing_candidates``, ``fresh_samples``, ``shared_luck``) take
``None``, "as the run recorded it".  A new run then gets :data:`NEW_RUN_DEFAULTS`, a
resumed run the value in its run.json, or, if its run.json predates the setting,
:data:`RECORDED_DEFAULTS` (what runs did before the setting existed).  :meth:`RunSettings.resolved` applies that rule.
"""
from __future__ import annotations

import dataclasses
import math
import numbers
import re
import types
from collections.abc import Mapping
from dataclasses import dataclass, field

from .cases import VALIDATION_RULES

__all__ = ["RunError", "SettingError", "RunSettings", "MUTABLE", "NEW_RUN_DEFAULTS", "SELECTION_LEVELS",
           "RECORDED_DEFAULTS", "RUN_FORMAT", "RUN_VERSION", "SEED_LIMIT", "fresh_base_seed",
           "FIDELITY_PHASES", "EXPLORING_PHASES", "REFERENCE_FIDELITY", "problem_fidelities",
           "check_problem_fidelity"]

RUN_FORMAT = "tethernet_ros.optimizer.run"
RUN_VERSION = 1

#: settings that may differ between a run and its resumption (they act after the
#: optimisation: racing and validation)
MUTABLE = frozenset({"iterations", "validation_samples", "validation_candidates",
                     "validation_rule", "validation_stop", "compare_reference",
                     "racing_candidates", "racing_round", "racing_budget", "racing_seed",
                     "racing_max_samples", "selection_level"})
#: the value of a ``None`` ("as recorded") setting for a new run; a callable takes the
#: :class:`~optimizer.cases.Case`
NEW_RUN_DEFAULTS = {
    # validate ranked designs in turn, as the replication benchmark that measured the
    # procedure did (docs/cases/replication.md: up to 10): under the Wilson rule a design
    # of true P_s 0.975 passes one 1000-sample validation with probability 0.0013
    # (docs/optimizer.md §6), so ten tries hardly weaken the confidence; with racing the
    # benchmark's runs spent 0.03-0.75 failed validations on average before a pass
    "validation_candidates": 10,
    "validation_rule": "wilson", "validation_stop": True, "racing_candidates": 5,
    # fresh samples where the objective is exact (Case 1: lower regret than common
    # samples with the shared-luck model in the replication benchmark,
    # docs/cases/replication.md); common random numbers where they compare the objective
    # (Case 2's mean T), with the constraint model taking their shared luck into account
    "fresh_samples": lambda case: not case.objective_from_samples,
    "shared_luck": True,
}
#: what the final choice's posterior probability and the race's clearing are taken
#: against: C_P itself ("requirement"), or the true P*_s at which the run's validation
#: passes half the time ("validation", :func:`optimizer.sequential.pass_level`: 0.9884
#: for 1000 samples at 98 % by the Wilson rule)
SELECTION_LEVELS = ("requirement", "validation")
#: the phases of a run that ``fidelity`` maps to a fidelity: the space-filling seed points
#: ("initial", the optimiser's phase of that name), the model-based iterations, the
#: racing and the validations
FIDELITY_PHASES = ("initial", "iterations", "racing", "validation")
#: the phases that may run at another fidelity than the reference: their estimates only
#: steer the search; racing and validation decide what a run claims, at the reference
EXPLORING_PHASES = ("initial", "iterations")
#: the problem as given (every problem has it; others come from ``problem.fidelities``)
REFERENCE_FIDELITY = "reference"
#: the value of a setting that a run directory of an older version does not record
RECORDED_DEFAULTS = {"sequential": False, "validation_candidates": 1,
                     "validation_rule": "estimate",
                     "validation_stop": False, "racing_candidates": 0,
                     "fresh_samples": False, "shared_luck": False,
                     "fidelity": {p: REFERENCE_FIDELITY for p in FIDELITY_PHASES}}
#: seeds are below this: the base seeds of fresh samples lie above it
#: (:func:`fresh_base_seed`)
SEED_LIMIT = 1_000_000
#: keys of ``optimizer_options`` that the run sets itself
_RESERVED_OPTIONS = frozenset({"n_initial", "n_iterations", "seed", "cheap_constraint",
                               "shared_luck"})
#: allowed range of each integer setting (None: no upper end)
_INT_RANGE = {"iterations": (0, None), "seed_points": (1, None), "samples": (1, None),
              "validation_samples": (0, None), "seed": (0, None),
              "sample_seed": (0, SEED_LIMIT - 1), "validation_seed": (0, SEED_LIMIT - 1),
              "validation_candidates": (1, None), "racing_candidates": (0, None),
              "racing_round": (1, None), "racing_budget": (0, None),
              "racing_seed": (0, SEED_LIMIT - 1), "racing_max_samples": (0, None)}


def fresh_base_seed(sample_seed: int, evaluation: int) -> int:
    """Base seed of the samples of evaluation ``evaluation`` (1-based) when every design
    gets fresh samples: ``(sample_seed + 1) * SEED_LIMIT + evaluation``, above every seed a
    setting may take, so fresh samples never repeat the validation's or the racing's."""
    return (int(sample_seed) + 1) * SEED_LIMIT + int(evaluation)


class RunError(ValueError):
    """A run cannot start or resume as asked (message: one line, says what to do)."""


class SettingError(RunError):
    """A setting outside its allowed range.  ``field``: its name; ``value``: what was
    given; ``requirement``: what it must be, the words after "must" (other settings named
    by their field names)."""

    def __init__(self, name: str, value, requirement: str):
        self.field, self.value, self.requirement = name, value, requirement
        super().__init__(f"{name}: got {value!r}; must {requirement}")

    def with_flags(self) -> str:
        """The message with every setting named as its command-line flag
        (``validation_seed`` -> ``--validation-seed``)."""
        names = "|".join(sorted(RunSettings.field_names(), key=len, reverse=True))

        def flag(name: str) -> str:
            return "--" + name.replace("_", "-")

        # (a quoted word, e.g. the phase 'iterations' of fidelity, is not a setting)
        requirement = re.sub(rf"(?<!')\b({names})\b(?!')", lambda m: flag(m.group(0)),
                             self.requirement)
        return f"{flag(self.field)} {self.value}: must {requirement}"


@dataclass(frozen=True)
class RunSettings:
    """What a run does; every field checked (:class:`SettingError`).

    Attributes:
        iterations: model-based iterations after the seed points (>= 0; the source's
            setup, docs/optimizer.md §4: 200).
        seed_points: space-filling seed designs (>= 1; docs/optimizer.md §4: 50).
        samples: Monte Carlo samples per design during optimisation (>= 1;
            docs/optimizer.md §2: 100).
        validation_samples: fresh samples to validate a chosen design with (>= 0; 0: no
            validation; source: 1000).
        seed: the optimiser's own seed (seed design, candidates, GP restarts; >= 0).
        sample_seed: Monte Carlo base seed of the optimisation samples (>= 0), the same for
            every design (common random numbers).
        validation_seed: base seed of the validation samples (>= 0); must differ from
            ``sample_seed`` when there is a validation (fresh samples).
        validation_candidates: validate the ranked designs in turn until one meets C_P, at
            most this many (>= 1), or None (module docstring: 10 for a new run).
        validation_rule: how a validation meets C_P, one of
            :data:`~optimizer.cases.VALIDATION_RULES`, or None (module docstring: "wilson"
            for a new run, a resumed run keeps its own, "estimate" if it predates the
            setting).
        validation_stop: end a failing validation at the failure that decides it, or None
            (module docstring).
        sequential: stop sampling a design once its feasibility is decided.
        min_probability: posterior-feasibility filter of the final choice, in [0, 1], or
            None (plain observed-feasible rule).
        compare_reference: also evaluate and validate the case's reference design
            (docs/model.md §9) with the optimisation and the validation samples.
        fresh_samples: every design gets samples of its own (base seed
            :func:`fresh_base_seed`) instead of the same ``sample_seed`` samples (common
            random numbers), so that the constraint model's observations are independent;
            or None (for a new run: fresh where the objective is exact, Case 1).
        shared_luck: with common random numbers, the constraint GP models the luck that
            all designs share (an error of variance C_P (1 - C_P) / samples common to
            every optimisation estimate, :class:`~optimizer.gp.GPModel`), instead of
            taking the estimates as independent; ignored with ``fresh_samples``; or None
            (module docstring).
        racing_candidates: race the first this many ranked designs on fresh samples
            before validating (:mod:`optimizer.racing`; 0: no racing), or None (module
            docstring).
        racing_round: samples per racing candidate and round (>= 1).
        racing_budget: the most racing samples in all (>= 0).
        racing_seed: base seed of the racing samples (< 1 000 000); must differ from
            ``sample_seed`` and ``validation_seed`` when racing.
        racing_max_samples: the most racing samples of one candidate, after which it is
            left undecided (>= 0; 0, the default: ``validation_samples``, as before this
            setting existed; docs/optimizer.md §5).
        selection_level: one of :data:`SELECTION_LEVELS`: the P*_s that the final
            ranking's posterior probability (``min_probability``) and the race's clearing
            are taken against (docs/optimizer.md §5).
        optimizer_options: further :class:`~optimizer.bayesopt.ConstrainedBayesOpt`
            settings (not ``n_initial``, ``n_iterations``, ``seed``, ``cheap_constraint``);
            kept as a read-only mapping.
        fidelity: phase of :data:`FIDELITY_PHASES` -> the fidelity its evaluations run
            at: :data:`REFERENCE_FIDELITY` (the problem as given; the default of every
            phase) or a name of ``problem.fidelities`` (the simulator's: "exploration",
            the implicit step at 2 ms with 8 sweeps and the early call,
            tethernet_ros/core/fidelity.py), checked against
            the problem when the run opens.  Only the :data:`EXPLORING_PHASES` ("initial":
            the seed points, "iterations") may leave the reference; "racing" and
            "validation" must stay at it (every claim a run reports is a reference-fidelity
            claim; docs/optimizer.md).  Kept as a read-only mapping of every phase.
    """

    iterations: int = 200
    seed_points: int = 50
    samples: int = 100
    validation_samples: int = 1000
    seed: int = 0
    sample_seed: int = 1
    validation_seed: int = 0
    validation_candidates: int | None = None
    validation_rule: str | None = None
    validation_stop: bool | None = None
    sequential: bool = True
    min_probability: float | None = 0.5
    compare_reference: bool = False
    optimizer_options: Mapping = field(default_factory=dict)
    fresh_samples: bool | None = None
    shared_luck: bool | None = None
    racing_candidates: int | None = None
    racing_round: int = 100
    racing_budget: int = 2000
    racing_seed: int = 2
    racing_max_samples: int = 0
    selection_level: str = "requirement"
    fidelity: Mapping = field(default_factory=dict)

    def __post_init__(self):
        for name, (low, high) in _INT_RANGE.items():
            value = getattr(self, name)
            if value is None and name in NEW_RUN_DEFAULTS:
                continue
            if (isinstance(value, bool) or not isinstance(value, numbers.Integral)
                    or value < low or (high is not None and value > high)):
                raise SettingError(name, value, f"be an integer >= {low}" + (
                    f" and <= {high}" if high is not None else ""))
            object.__setattr__(self, name, int(value))
        rule = self.validation_rule
        if not (rule in VALIDATION_RULES or (rule is None and "validation_rule" in NEW_RUN_DEFAULTS)):
            raise SettingError("validation_rule", rule, f"be one of {', '.join(VALIDATION_RULES)}")
        if self.selection_level not in SELECTION_LEVELS:
            raise SettingError("selection_level", self.selection_level,
                               f"be one of {', '.join(SELECTION_LEVELS)}")
        for name in ("validation_stop", "sequential", "compare_reference", "fresh_samples",
                     "shared_luck"):
            value = getattr(self, name)
            if not (isinstance(value, bool) or (value is None and name in NEW_RUN_DEFAULTS)):
                raise SettingError(name, value, "be True or False")
        p = self.min_probability
        if p is not None:
            if (isinstance(p, bool) or not isinstance(p, numbers.Real)
                    or not (math.isfinite(p) and 0.0 <= p <= 1.0)):
                raise SettingError("min_probability", p, "be None or a number in [0, 1]")
            object.__setattr__(self, "min_probability", float(p))
        if self.validation_samples and self.validation_seed == self.sample_seed:
            raise SettingError("validation_seed", self.validation_seed,
                               "differ from sample_seed (a validation draws fresh noise, "
                               "not the optimisation's)")
        if self.racing_candidates != 0 and self.racing_seed in (self.sample_seed,
                                                                 self.validation_seed):
            raise SettingError("racing_seed", self.racing_seed,
                               "differ from sample_seed and validation_seed (racing draws "
                               "fresh noise)")
        options = self.optimizer_options
        if not isinstance(options, Mapping):
            raise SettingError("optimizer_options", options, "be a mapping")
        bad = sorted(set(options) & _RESERVED_OPTIONS)
        if bad:
            raise SettingError("optimizer_options", dict(options),
                               f"not set {bad} (they are settings of the run)")
        object.__setattr__(self, "optimizer_options", types.MappingProxyType(dict(options)))
        object.__setattr__(self, "fidelity", types.MappingProxyType(_fidelity(self.fidelity)))

    def replace(self, **changes) -> RunSettings:
        """A copy with ``changes`` (checked again)."""
        return dataclasses.replace(self, **changes)

    def resolved(self, recorded: Mapping | None, case=None) -> RunSettings:
        """The ``None`` settings made definite: from ``recorded`` (a resumed run's
        run.json; :data:`RECORDED_DEFAULTS` where it lacks them), or from
        :data:`NEW_RUN_DEFAULTS` when ``recorded`` is None (a new run of ``case``)."""
        changes = {}
        for name, new in NEW_RUN_DEFAULTS.items():
            if getattr(self, name) is None:
                if recorded is not None:
                    changes[name] = recorded.get(name, RECORDED_DEFAULTS[name])
                elif callable(new):
                    if case is None:
                        raise ValueError(f"resolving {name} for a new run needs its case")
                    changes[name] = new(case)
                else:
                    changes[name] = new
        return self.replace(**changes) if changes else self

    def record(self, case_name: str, problem_settings: Mapping) -> dict:
        """The JSON-ready run.json of a run of case ``case_name`` with these settings and
        the problem's own settings (:meth:`optimizer.problem.DesignProblem.settings`)."""
        if any(getattr(self, name) is None for name in NEW_RUN_DEFAULTS):
            raise ValueError("record() needs resolved settings (RunSettings.resolved)")
        return {"format": RUN_FORMAT, "version": RUN_VERSION, "case": case_name,
                "iterations": self.iterations, "seed_points": self.seed_points,
                "samples": self.samples, "validation_samples": self.validation_samples,
                "seed": self.seed, "sample_seed": self.sample_seed,
                "validation_seed": self.validation_seed,
                "validation_candidates": self.validation_candidates,
                "validation_rule": self.validation_rule,
                "validation_stop": self.validation_stop, "sequential": self.sequential,
                **problem_settings, "optimizer_options": dict(self.optimizer_options),
                "min_probability": self.min_probability,
                "compare_reference": self.compare_reference,
                "fresh_samples": self.fresh_samples, "shared_luck": self.shared_luck,
                "racing_candidates": self.racing_candidates,
                "racing_round": self.racing_round, "racing_budget": self.racing_budget,
                "racing_seed": self.racing_seed,
                "racing_max_samples": self.racing_max_samples,
                "selection_level": self.selection_level,
                "fidelity": dict(self.fidelity)}

    @classmethod
    def field_names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in dataclasses.fields(cls))


def _fidelity(value) -> dict:
    """The ``fidelity`` setting checked and made whole: every phase of
    :data:`FIDELITY_PHASES`, in that order, the reference where ``value`` names none."""
    phases = ", ".join(repr(p) for p in FIDELITY_PHASES)
    if not isinstance(value, Mapping):
        raise SettingError("fidelity", value, f"be a mapping of phases ({phases}) to "
                           "names of fidelities")
    unknown = sorted(str(k) for k in value if k not in FIDELITY_PHASES)
    if unknown:
        raise SettingError("fidelity", dict(value), f"name only the phases {phases} "
                           f"(unknown: {', '.join(repr(k) for k in unknown)})")
    whole = {p: value.get(p, REFERENCE_FIDELITY) for p in FIDELITY_PHASES}
    bad = [p for p, name in whole.items() if not isinstance(name, str) or not name]
    if bad:
        raise SettingError("fidelity", dict(value), "map each phase to the name of one of "
                           f"its fidelities (a non-empty string; not for {', '.join(repr(p) for p in bad)})")
    claims = [p for p in FIDELITY_PHASES
              if p not in EXPLORING_PHASES and whole[p] != REFERENCE_FIDELITY]
    if claims:
        raise SettingError("fidelity", dict(value),
                           f"keep {' and '.join(repr(p) for p in claims)} at "
                           f"{REFERENCE_FIDELITY!r}: racing and validation decide what a "
                           "run claims, and every claim stands at the reference "
                           "(docs/optimizer.md, fidelities)")
    return whole


def problem_fidelities(problem) -> tuple[str, ...]:
    """The fidelities ``problem`` evaluates at: :data:`REFERENCE_FIDELITY` and those of
    its optional ``fidelities`` attribute (a problem with others has ``at_fidelity(name)
    -> DesignProblem``, :class:`optimizer.problem.DesignProblem`)."""
    names = tuple(getattr(problem, "fidelities", ()) or ())
    return (REFERENCE_FIDELITY, *[n for n in names if n != REFERENCE_FIDELITY])


def check_problem_fidelity(settings: RunSettings, problem) -> None:
    """SettingError when ``settings.fidelity`` names a fidelity that ``problem`` lacks
    (naming the phase and the problem's fidelities); RunError when ``problem.at_fidelity``
    refuses it (a ValueError, e.g. a configuration it cannot be applied to)."""
    allowed = problem_fidelities(problem)
    for phase, name in settings.fidelity.items():
        if name not in allowed:
            raise SettingError("fidelity", dict(settings.fidelity),
                               f"map phase {phase!r} to one of the problem's fidelities: "
                               f"{', '.join(repr(a) for a in allowed)}")
        if name != REFERENCE_FIDELITY:
            try:                         # before the run starts, not at its first such design
                problem.at_fidelity(name)
            except ValueError as exc:
                raise RunError(f"fidelity {name!r} of phase {phase!r} does not apply to "
                               f"this problem: {exc}") from None
