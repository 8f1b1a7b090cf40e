"""Reliability-constrained Bayesian optimisation over a box (docs/optimizer.md §4): the ask/tell
optimiser :class:`ConstrainedBayesOpt` (:func:`optimizer.loop.minimize` drives it).

Simulator-independent: the expensive function is any callable. The optimiser minimises an
objective ``f(x)`` over a box subject to

* **coupled (modelled) constraints** ``g_j(x) >= threshold_j``, observed together with
  the objective, possibly noisily (e.g. a success probability estimated from N Monte Carlo
  samples, with the variance of :func:`~optimizer.observation.binomial_observation`), each
  modelled by its own Gaussian process (:mod:`optimizer.gp`); and
* an optional **cheap deterministic constraint** ``cheap_constraint(x) -> bool`` (e.g. the
  system mass ``m_a(x) <= 15 kg``) that simply excludes points: points failing it are never
  proposed, so the expensive function never sees them.

The next point maximises the acquisition of :mod:`optimizer.acquisition` (probability of
feasibility, then EI x PF with the expected-improvement-plus safeguard) over
``n_candidates`` uniform random points of the unit cube plus Gaussian perturbations of the
best observed points, those failing the cheap constraint removed, the best ``n_polish``
polished with L-BFGS-B.  Hyperparameter fits are deterministic given the data (fixed
``random_state`` derived from ``seed`` and the number of observations, fixed number of
restarts).

Active set: when more than ``active_set`` observations exist, GPs are fitted on a
deterministic subset: the ``active_set // 4`` observed-feasible points with the lowest
objective (ties: earlier first), then the most recent observations until ``active_set``
points are chosen.

Reproducibility / checkpointing: all randomness comes from the optimiser's own
``numpy.random.Generator`` (PCG64), whose state is part of :meth:`state_dict`. A state
saved after :meth:`ConstrainedBayesOpt.tell` and restored with
:meth:`ConstrainedBayesOpt.from_state_dict` produces exactly the same subsequent asks
(bit for bit, same platform / library versions) as the uninterrupted optimiser;
:func:`optimizer.loop.minimize` checkpoints it after every evaluation.
"""

from __future__ import annotations

import json
import math
import warnings
from collections.abc import Callable, Mapping, Sequence

import numpy as np
from skopt.sampler import Sobol
from skopt.space import Space

from .acquisition import (expected_improvement_plus, log_acquisition, log_probability_feasible,
                          maximise_acquisition)
from .candidates import DUPLICATE_TOL, away_from_evaluated, candidate_centres, candidate_points
from .gp import GPModel
from .jsonio import json_clean
from .observation import Observation

__all__ = ["ConstrainedBayesOpt", "DUPLICATE_TOL"]

_STATE_KIND = "ConstrainedBayesOpt"


class ConstrainedBayesOpt:
    """Ask/tell constrained Bayesian optimiser over a box.

    Args:
        bounds: ``[(lower, upper), ...]`` per variable, in the problem's units.
        constraints: coupled constraints ``name -> threshold``; a point is feasible when
            every observed value is ``>= threshold`` (e.g. ``{"p_success": 0.98}``).
        cheap_constraint: optional ``f(x) -> bool`` (x in problem units, shape ``(d,)``);
            True means allowed. Must be cheap (called on every acquisition candidate).
        n_initial: size of the space-filling seed design (randomly shifted Sobol sequence
            of ``skopt.sampler.Sobol`` seeded by ``seed``, filtered by the cheap
            constraint, first ``n_initial`` kept). The first ``n_initial`` observations,
            whatever their origin, count as the seed phase.
        n_iterations: model-based iterations after the seed phase (budget used by
            :func:`minimize`; :meth:`ask` itself never stops).
        active_set: the most observations a GP is fitted on (see module docstring).
        exploration_ratio: EI+ ratio (0 disables the safeguard).
        seed: seed of the initial design, the candidate generator and GP restarts.
        n_candidates: random candidates per acquisition maximisation (default
            ``clip(1000 d, 2000, 10000)``); a quarter as many local candidates are added.
        n_polish: candidates polished with L-BFGS-B.
        n_restarts_gp: extra random restarts of each GP hyperparameter fit.
        max_eiplus_tries: EI+ re-maximisations at most.
        shared_luck: per coupled constraint, the variance of an error that all its
            observations share (e.g. ``C_P (1 - C_P) / N`` for P*_s estimated on the same N
            samples for every design, common random numbers); the constraint GP then
            takes it into account (:class:`~optimizer.gp.GPModel`, ``shared_var``), and
            the evidence passed to :meth:`ranked_feasible` (fresh samples) does not share
            it.  None: independent observations.
    """

    def __init__(self, bounds: Sequence[Sequence[float]], constraints: Mapping[str, float],
                 cheap_constraint: Callable[[np.ndarray], bool] | None = None, *,
                 n_initial: int = 50, n_iterations: int = 200, active_set: int = 200,
                 exploration_ratio: float = 0.5, seed: int = 0,
                 n_candidates: int | None = None, n_polish: int = 5,
                 n_restarts_gp: int = 2, max_eiplus_tries: int = 5,
                 shared_luck: Mapping[str, float] | None = None):
        b = np.asarray(bounds, dtype=float)
        if b.ndim != 2 or b.shape[1] != 2 or b.shape[0] < 1:
            raise ValueError(f"bounds must be a sequence of (lower, upper) pairs, got {bounds!r}")
        if not np.all(np.isfinite(b)) or np.any(b[:, 1] <= b[:, 0]):
            raise ValueError(f"bounds must be finite with lower < upper, got {b.tolist()}")
        if n_initial < 1 or n_iterations < 0 or active_set < 2:
            raise ValueError("need n_initial >= 1, n_iterations >= 0, active_set >= 2")
        self.lower, self.upper = b[:, 0].copy(), b[:, 1].copy()
        self.dim = b.shape[0]
        self.constraints = {str(k): float(v) for k, v in constraints.items()}
        self.cheap_constraint = cheap_constraint
        self.n_initial = int(n_initial)
        self.n_iterations = int(n_iterations)
        self.active_set = int(active_set)
        self.exploration_ratio = float(exploration_ratio)
        self.seed = int(seed)
        self.n_candidates = int(n_candidates if n_candidates is not None
                                else min(max(1000 * self.dim, 2000), 10000))
        self.n_polish = int(n_polish)
        self.n_restarts_gp = int(n_restarts_gp)
        self.max_eiplus_tries = int(max_eiplus_tries)
        self.shared_luck = ({str(k): float(v) for k, v in shared_luck.items()}
                            if shared_luck else None)
        self.history: list[Observation] = []
        self.last_ask_info: dict = {}
        self._rng = np.random.default_rng(self.seed)
        self._last_ask_x: np.ndarray | None = None
        self._initial_design = self._make_initial_design()

    # ------------------------------------------------------------------ units
    def to_unit(self, x) -> np.ndarray:
        return (np.asarray(x, dtype=float) - self.lower) / (self.upper - self.lower)

    def from_unit(self, u) -> np.ndarray:
        return self.lower + np.asarray(u, dtype=float) * (self.upper - self.lower)

    def _cheap_ok(self, U) -> np.ndarray:
        U = np.atleast_2d(U)
        if self.cheap_constraint is None:
            return np.ones(len(U), dtype=bool)
        return np.fromiter((bool(self.cheap_constraint(self.from_unit(u))) for u in U),
                           dtype=bool, count=len(U))

    def _make_initial_design(self) -> np.ndarray:
        space = Space([(0.0, 1.0)] * self.dim)
        n = 1 << max(6, math.ceil(math.log2(4 * self.n_initial)))
        while True:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                U = np.asarray(Sobol(randomize=True).generate(space.dimensions, n,
                                                              random_state=self.seed), float)
            U = U[self._cheap_ok(U)]
            if len(U) >= self.n_initial:
                return U[: self.n_initial]
            if n >= 1 << 16:
                raise ValueError(
                    f"cheap_constraint admits only {len(U)} of {n} space-filling points; "
                    "the allowed part of the box is too small or empty")
            n *= 4

    # ------------------------------------------------------------------ data
    @property
    def n_evaluations(self) -> int:
        return len(self.history)

    @property
    def done(self) -> bool:
        """True once ``n_initial + n_iterations`` observations have been told."""
        return len(self.history) >= self.n_initial + self.n_iterations

    def _active_indices(self) -> np.ndarray:
        n = len(self.history)
        if n <= self.active_set:
            return np.arange(n)
        feas = [i for i, o in enumerate(self.history) if o.feasible]
        feas.sort(key=lambda i: (self.history[i].objective, i))
        chosen = set(feas[: self.active_set // 4])
        i = n - 1
        while len(chosen) < self.active_set:
            chosen.add(i)
            i -= 1
        return np.array(sorted(chosen))

    def _fit_models(self, idx, objective: bool = True, evidence=()):
        H = [self.history[i] for i in idx] + list(evidence)
        U = self.to_unit(np.array([o.x for o in H]))
        rs = (self.seed * 7919 + len(self.history) * 31) % (2**31 - 1)
        obj = (GPModel(U, [o.objective for o in H], random_state=rs, n_restarts=self.n_restarts_gp)
               if objective else None)
        cons = {}
        shared_mask = [1.0] * len(idx) + [0.0] * len(evidence)   # evidence: fresh samples
        for j, name in enumerate(self.constraints):
            var = np.array([o.constraint_variances.get(name, 0.0) for o in H])
            shared = (self.shared_luck or {}).get(name, 0.0)
            cons[name] = GPModel(U, [o.constraints[name] for o in H], var if np.any(var > 0) else None,
                             random_state=(rs + 104729 * (j + 1)) % (2**31 - 1),
                             n_restarts=self.n_restarts_gp, shared_var=shared,
                             shared_mask=shared_mask if shared else None)
        return U, H, obj, cons

    # ------------------------------------------------------------------ ask / tell
    def _maximise(self, obj, cons, incumbent, cand, cand_acq=None):
        """:func:`~optimizer.acquisition.maximise_acquisition` with this optimiser's
        thresholds, polish count and cheap constraint; returns (u, log_acq)."""
        return maximise_acquisition(obj, cons, self.constraints, incumbent, cand, self.n_polish,
                                    self._cheap_ok, cand_acq)

    def ask(self) -> np.ndarray:
        """Next design to evaluate (problem units, shape ``(d,)``).

        Call :meth:`tell` with its result before asking again: a repeated ask in the
        model-based phase draws fresh candidates and may return a different point.
        Diagnostics of the choice are left in ``last_ask_info``.
        """
        n = len(self.history)
        if n < self.n_initial:
            x = self.from_unit(self._initial_design[n])
            self.last_ask_info = {"phase": "initial", "index": n}
            self._last_ask_x = x.copy()
            return x
        idx = self._active_indices()
        U, H, obj, cons = self._fit_models(idx)
        feas = np.array([o.feasible for o in H])
        incumbent = None
        if feas.any():
            mu_obs, _ = obj.predict(U[feas])
            incumbent = float(np.min(mu_obs))
        centres = candidate_centres(U, [o.objective for o in H], feas, cons, self.constraints)
        cand = candidate_points(self._rng, self.n_candidates, centres)
        cand = cand[self._cheap_ok(cand)]
        if len(cand) == 0:
            raise RuntimeError("no acquisition candidate satisfies cheap_constraint")

        tries, factors = 0, []
        if incumbent is None:
            u, la = self._maximise(None, cons, None, cand)
            phase = "feasibility"
        else:
            phase = "ei"
            base_acq = log_acquisition(obj, cons, self.constraints, incumbent, cand)

            def maximise(model):
                if model is obj:
                    return self._maximise(obj, cons, incumbent, cand, base_acq)[0]
                inc = float(np.min(model.predict(U[feas])[0]))
                return self._maximise(model, cons, inc, cand)[0]

            if self.exploration_ratio > 0:
                u, tries, factors = expected_improvement_plus(
                    maximise, obj, n, self.exploration_ratio, self.max_eiplus_tries)
            else:
                u = maximise(obj)
            la = float(log_acquisition(obj, cons, self.constraints, incumbent, u[None, :])[0])
        # never a design already evaluated (candidates.away_from_evaluated says why)
        u, la, deduplicated = away_from_evaluated(
            u, la, cand, self.to_unit(np.array([o.x for o in self.history])),
            (lambda P: log_probability_feasible(cons, self.constraints, P)) if incumbent is None
            else (lambda P: log_acquisition(obj, cons, self.constraints, incumbent, P)))
        mu, sd = obj.predict(u[None, :])
        self.last_ask_info = {
            "deduplicated": deduplicated,
            "phase": phase,
            "log_acquisition": float(la),
            "probability_feasible": float(np.exp(log_probability_feasible(cons, self.constraints, u[None, :])[0])),
            "predicted_objective": float(mu[0] * obj.y_std + obj.y_mean),
            "predicted_objective_std": float(sd[0] * obj.y_std),
            "objective_noise_std": float(obj.noise_sd * obj.y_std),
            "eiplus_tries": int(tries),
            "eiplus_factors": factors,
            "n_active": int(len(idx)),
        }
        x = self.from_unit(u)
        self._last_ask_x = x.copy()
        return x

    def tell(self, x, objective: float, constraints: Mapping[str, float],
             constraint_variances: Mapping[str, float] | None = None,
             info: Mapping | None = None) -> Observation:
        """Record an evaluation and return it as an :class:`Observation`.

        ``constraints`` must give a finite value for every configured constraint name;
        ``constraint_variances`` (optional, per name, >= 0) are known observation
        variances in the constraint's units squared. ``info`` must be JSON-serialisable
        (numpy scalars/arrays are converted).
        """
        x = np.array(x, dtype=float).reshape(-1)
        if x.shape != (self.dim,) or not np.all(np.isfinite(x)):
            raise ValueError(f"x must be {self.dim} finite numbers, got {x!r}")
        objective = float(objective)
        if not math.isfinite(objective):
            raise ValueError(f"objective must be finite, got {objective!r} at x={x.tolist()}")
        if set(constraints) != set(self.constraints):
            raise ValueError(f"constraints must have exactly the keys {sorted(self.constraints)}, "
                             f"got {sorted(constraints)}")
        cons = {k: float(constraints[k]) for k in self.constraints}
        if not all(math.isfinite(v) for v in cons.values()):
            raise ValueError(f"constraint values must be finite, got {cons}")
        var = {k: float(v) for k, v in (constraint_variances or {}).items()}
        bad = [k for k, v in var.items() if k not in self.constraints or not v >= 0 or not math.isfinite(v)]
        if bad:
            raise ValueError(f"bad constraint_variances entries {bad}: names must be constraints, "
                             "values finite and >= 0")
        info = json_clean(dict(info or {}))
        try:
            json.dumps(info)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"info must be JSON-serialisable: {exc}") from exc
        feasible = all(cons[k] >= t for k, t in self.constraints.items())
        acq = {}
        if self._last_ask_x is not None and np.array_equal(self._last_ask_x, x):
            acq = dict(self.last_ask_info)
        obs = Observation(x=x, objective=objective, constraints=cons, constraint_variances=var,
                          feasible=feasible, info=info, acquisition=acq)
        self.history.append(obs)
        self._last_ask_x = None
        return obs

    def best_feasible(self, min_probability: float | None = None) -> Observation | None:
        """Best evaluated design: lowest observed objective among observations whose
        *observed* constraint values were all feasible (earliest on ties); None if none.

        With noisy constraints (e.g. ``P_s`` from 100 samples) the plain rule suffers a
        winner's curse: a design with true ``p = 0.98`` shows ``>= 0.98`` about two times
        in three, and the lowest-objective lucky one tends to be truly infeasible. Passing
        ``min_probability`` (e.g. 0.5) additionally requires the posterior probability
        that every coupled constraint holds at the design (constraint GPs fitted on the
        active set, latent function, i.e. observation noise removed) to be at least that
        value, which pools the evidence of neighbouring evaluations. Either way the
        winner should be validated with a larger fresh sample (docs/optimizer.md §6: 1000 samples).
        """
        ranked = self.ranked_feasible(min_probability)
        return ranked[0] if ranked else None

    def ranked_feasible(self, min_probability: float | None = None,
                        evidence: Sequence[Observation] = (),
                        levels: Mapping[str, float] | None = None) -> list[Observation]:
        """The designs :meth:`best_feasible` chooses from, best first: observed feasible
        (and with ``min_probability``, at least that posterior probability of
        feasibility), ordered by observed objective, earlier evaluations first on ties.
        ``evidence``: further observations (e.g. validations of designs of the history)
        that the constraint GPs are fitted to as well; they are never candidates.
        ``levels``: thresholds that the posterior probability is taken against instead
        of the constraints' own (a constraint not named keeps its own)."""
        cand = [i for i, o in enumerate(self.history) if o.feasible]
        if cand and min_probability is not None and self.constraints:
            _, _, _, cons = self._fit_models(self._active_indices(), objective=False,
                                             evidence=evidence)
            U = self.to_unit(np.array([self.history[i].x for i in cand]))
            pf = np.exp(log_probability_feasible(cons, {**self.constraints, **(levels or {})},
                                                 U))
            cand = [i for i, p in zip(cand, pf) if p >= min_probability]
        return sorted((self.history[i] for i in cand), key=lambda o: o.objective)

    # ------------------------------------------------------------------ state
    def _settings(self) -> dict:
        out = {
            "n_initial": self.n_initial, "n_iterations": self.n_iterations,
            "active_set": self.active_set, "exploration_ratio": self.exploration_ratio,
            "seed": self.seed, "n_candidates": self.n_candidates, "n_polish": self.n_polish,
            "n_restarts_gp": self.n_restarts_gp, "max_eiplus_tries": self.max_eiplus_tries,
        }
        if self.shared_luck:            # absent when off: checkpoints from before it match
            out["shared_luck"] = dict(self.shared_luck)
        return out

    def state_dict(self) -> dict:
        """JSON-serialisable complete state (settings, RNG state, seed design, history).

        The cheap constraint is a callable and is not stored: pass it again to
        :meth:`from_state_dict`.
        """
        return {
            "kind": _STATE_KIND,
            "bounds": [[float(a), float(b)] for a, b in zip(self.lower, self.upper)],
            "constraints": dict(self.constraints),
            "has_cheap_constraint": self.cheap_constraint is not None,
            "settings": self._settings(),
            "rng_state": json_clean(self._rng.bit_generator.state),
            "initial_design": self._initial_design.tolist(),
            "history": [o.to_dict() for o in self.history],
        }

    @classmethod
    def from_state_dict(cls, state: Mapping, cheap_constraint=None, **overrides) -> ConstrainedBayesOpt:
        """Rebuild an optimiser from :meth:`state_dict`. ``overrides`` may change
        ``n_iterations`` (e.g. to extend the budget); other settings come from the state."""
        if state.get("kind") != _STATE_KIND:
            raise ValueError("not a ConstrainedBayesOpt state")
        if bool(state["has_cheap_constraint"]) != (cheap_constraint is not None):
            raise ValueError("the saved optimiser %s a cheap constraint; pass the same one"
                             % ("had" if state["has_cheap_constraint"] else "had no"))
        bad = set(overrides) - {"n_iterations"}
        if bad:
            raise ValueError(f"only n_iterations may be overridden, got {sorted(bad)}")
        settings = {**state["settings"], **overrides}
        self = cls.__new__(cls)
        # replicate __init__ without regenerating the seed design
        b = np.asarray(state["bounds"], dtype=float)
        self.lower, self.upper, self.dim = b[:, 0].copy(), b[:, 1].copy(), b.shape[0]
        self.constraints = {str(k): float(v) for k, v in state["constraints"].items()}
        self.cheap_constraint = cheap_constraint
        for k in ("n_initial", "n_iterations", "active_set", "seed", "n_candidates", "n_polish",
                  "n_restarts_gp", "max_eiplus_tries"):
            setattr(self, k, int(settings[k]))
        self.exploration_ratio = float(settings["exploration_ratio"])
        self.shared_luck = settings.get("shared_luck")
        self._rng = np.random.default_rng()
        self._rng.bit_generator.state = state["rng_state"]
        self._initial_design = np.asarray(state["initial_design"], dtype=float)
        self.history = [Observation.from_dict(o) for o in state["history"]]
        self.last_ask_info, self._last_ask_x = {}, None
        return self
