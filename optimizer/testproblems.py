"""Standard constrained Bayesian-optimisation test problems with known optima.

Every problem uses the optimiser's convention: minimise ``objective(x)`` subject to
coupled constraints ``g_j(x) >= threshold_j`` (published ``c(x) <= 0`` constraints are
rewritten as ``g = -c >= 0``) and, optionally, a cheap constraint that excludes points.
``evaluate(x)`` returns the tuple expected by :func:`optimizer.loop.minimize`.

Reference optima are *computed*, not quoted: :meth:`TestProblem.reference_optimum`
evaluates a dense grid, then polishes the best feasible grid points with SLSQP on the
true constraints. Published values are given in docstrings for comparison only.
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize as _scipy_minimize
from scipy.stats import beta, norm

from .observation import binomial_observation, wilson_interval

__all__ = ["TestProblem", "Gardner2014", "Gramacy2016", "NoisyGramacy2016", "BernoulliGramacy2016",
           "LatentDifficulty", "PROBLEMS"]


class TestProblem:
    """Base class. Subclasses define ``name``, ``bounds``, ``thresholds``,
    ``objective(x)``, ``true_constraints(x)`` and optionally ``cheap_constraint``."""

    __test__ = False  # not a pytest test class
    name: str = ""
    bounds: list[tuple[float, float]] = []
    thresholds: dict[str, float] = {}
    cheap_constraint: Callable[[np.ndarray], bool] | None = None
    grid_points: int = 1001  # per dimension, for reference_optimum

    def objective(self, x) -> float:
        raise NotImplementedError

    def true_constraints(self, x) -> dict[str, float]:
        """Noise-free constraint values (feasible if ``>= thresholds``)."""
        raise NotImplementedError

    def evaluate(self, x):
        """``(objective, constraints, variances, info)`` as observed by the optimiser."""
        return self.objective(x), self.true_constraints(x), None, {}

    def is_feasible(self, x, tol: float = 0.0) -> bool:
        """True (noise-free) feasibility, constraint values allowed ``tol`` below threshold."""
        x = np.asarray(x, dtype=float)
        if self.cheap_constraint is not None and not self.cheap_constraint(x):
            return False
        g = self.true_constraints(x)
        return all(g[k] >= t - tol for k, t in self.thresholds.items())

    # vectorised helpers for the grid search (default: loop)
    def _grid_values(self, X):
        f = np.array([self.objective(x) for x in X])
        ok = np.array([self.is_feasible(x) for x in X])
        return f, ok

    def reference_optimum(self) -> tuple[np.ndarray, float]:
        """``(x*, f*)``: dense grid over the box, then SLSQP polish of the 20 best
        feasible grid points on the true constraints (cached per instance)."""
        if getattr(self, "_ref", None) is not None:
            return self._ref
        axes = [np.linspace(lo, hi, self.grid_points) for lo, hi in self.bounds]
        X = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, len(axes))
        f, ok = self._grid_values(X)
        if not ok.any():
            raise RuntimeError(f"{self.name}: no feasible grid point")
        idx = np.flatnonzero(ok)[np.argsort(f[ok], kind="stable")[:20]]
        best_x, best_f = X[idx[0]], float(f[idx[0]])
        cons = [{"type": "ineq", "fun": self._slsqp_constraints}]
        for i in idx:
            res = _scipy_minimize(self.objective, X[i], method="SLSQP", bounds=self.bounds,
                                  constraints=cons, options={"ftol": 1e-12, "maxiter": 500})
            x = np.clip(res.x, [b[0] for b in self.bounds], [b[1] for b in self.bounds])
            fx = float(self.objective(x))
            if fx < best_f and self.is_feasible(x, tol=1e-9):
                best_x, best_f = x, fx
        self._ref = (np.asarray(best_x, dtype=float), best_f)
        return self._ref

    def _slsqp_constraints(self, x) -> np.ndarray:
        """Smooth constraint margins, all ``>= 0`` exactly where x is truly feasible."""
        g = self.true_constraints(x)
        return np.array([g[k] - t for k, t in self.thresholds.items()])


class Gardner2014(TestProblem):
    """Toy problem of Gardner, Kusner, Xu, Weinberger & Cunningham, "Bayesian
    optimization with inequality constraints", ICML 2014 (PMLR 32(2):937-945), sec. 5:

        minimise  cos(2 x1) cos(x2) + sin(x1)
        s.t.      cos(x1) cos(x2) - sin(x1) sin(x2) <= 0.5,   x in [0, 6]^2.

    Coupled constraint ``g = 0.5 - cos(x1) cos(x2) + sin(x1) sin(x2) >= 0``.
    Computed optimum: f* = -2 at x* = (3 pi / 2, 0) (on the bound x2 = 0; the constraint,
    ``cos(x1 + x2) <= 0.5``, is inactive there, g = 0.5).
    """

    name = "gardner2014"
    bounds = [(0.0, 6.0), (0.0, 6.0)]
    thresholds = {"g": 0.0}

    def objective(self, x):
        return float(math.cos(2 * x[0]) * math.cos(x[1]) + math.sin(x[0]))

    def true_constraints(self, x):
        return {"g": float(0.5 - (math.cos(x[0]) * math.cos(x[1]) - math.sin(x[0]) * math.sin(x[1])))}

    def _grid_values(self, X):
        f = np.cos(2 * X[:, 0]) * np.cos(X[:, 1]) + np.sin(X[:, 0])
        ok = 0.5 - np.cos(X[:, 0] + X[:, 1]) >= 0
        return f, ok


def _gramacy_c1(x):
    return 1.5 - x[..., 0] - 2 * x[..., 1] - 0.5 * np.sin(2 * np.pi * (x[..., 0] ** 2 - 2 * x[..., 1]))


def _gramacy_c2(x):
    return x[..., 0] ** 2 + x[..., 1] ** 2 - 1.5


class Gramacy2016(TestProblem):
    """Problem of Gramacy, Gray, Le Digabel, Lee, Ranjan, Wells & Wild, "Modeling an
    augmented Lagrangian for blackbox constrained optimization", Technometrics 58(1):1-11,
    2016 (the 2-d "toy" problem with a linear objective and two constraints):

        minimise  x1 + x2
        s.t.      c1 = 3/2 - x1 - 2 x2 - 1/2 sin(2 pi (x1^2 - 2 x2)) <= 0
                  c2 = x1^2 + x2^2 - 3/2 <= 0,                  x in [0, 1]^2.

    Coupled constraints ``g1 = -c1 >= 0``, ``g2 = -c2 >= 0``. Published optimum
    f* ~ 0.5998 at (0.1954, 0.4044); :meth:`reference_optimum` recomputes it.
    """

    name = "gramacy2016"
    bounds = [(0.0, 1.0), (0.0, 1.0)]
    thresholds = {"g1": 0.0, "g2": 0.0}

    def objective(self, x):
        return float(x[0] + x[1])

    def true_constraints(self, x):
        x = np.asarray(x, dtype=float)
        return {"g1": float(-_gramacy_c1(x)), "g2": float(-_gramacy_c2(x))}

    def _grid_values(self, X):
        return X.sum(1), (_gramacy_c1(X) <= 0) & (_gramacy_c2(X) <= 0)


class NoisyGramacy2016(TestProblem):
    """Reliability-constrained variant of :class:`Gramacy2016` mirroring docs/optimizer.md §1-2
    (``P*_s >= 98 %`` estimated from N = 100 Monte Carlo samples, mass constraint cheap).

    The first constraint becomes a success probability ``p(x) = Phi(-c1(x) / s)``
    (default ``s = 0.1``); an evaluation draws ``k ~ Binomial(N, p(x))`` and reports
    ``p_success = k / N`` with variance from :func:`binomial_observation`. Feasible when
    ``p(x) >= p_min`` (default 0.98), i.e. ``c1(x) <= -s Phi^{-1}(p_min)``. ``c2 <= 0`` is
    the cheap deterministic constraint. The draw is seeded by ``(noise_seed, x)``, so
    re-evaluating the same x gives the same k (common random numbers, reproducible).
    Objective ``x1 + x2`` (exact).
    """

    name = "noisy_gramacy2016"
    bounds = [(0.0, 1.0), (0.0, 1.0)]

    def __init__(self, n_samples: int = 100, p_min: float = 0.98, s: float = 0.1,
                 noise_seed: int = 0):
        self.n_samples, self.p_min, self.s, self.noise_seed = n_samples, p_min, s, noise_seed
        self.thresholds = {"p_success": p_min}

    @staticmethod
    def cheap_constraint(x) -> bool:
        return bool(_gramacy_c2(np.asarray(x, dtype=float)) <= 0)

    def objective(self, x):
        return float(x[0] + x[1])

    def success_probability(self, x) -> float:
        """True ``p(x)``."""
        return float(norm.cdf(-_gramacy_c1(np.asarray(x, dtype=float)) / self.s))

    def true_constraints(self, x):
        return {"p_success": self.success_probability(x)}

    def evaluate(self, x):
        x = np.asarray(x, dtype=float)
        p = self.success_probability(x)
        rng = np.random.default_rng([self.noise_seed, zlib.crc32(x.tobytes())])
        k = int(rng.binomial(self.n_samples, p))
        value, var = binomial_observation(k, self.n_samples)
        return self.objective(x), {"p_success": value}, {"p_success": var}, {
            "successes": k, "trials": self.n_samples, "p_true": p}

    def _grid_values(self, X):
        margin = -self.s * norm.ppf(self.p_min)
        return X.sum(1), (_gramacy_c1(X) <= margin) & (_gramacy_c2(X) <= 0)

    def _slsqp_constraints(self, x):
        x = np.asarray(x, dtype=float)
        margin = -self.s * norm.ppf(self.p_min)
        return np.array([margin - _gramacy_c1(x), -_gramacy_c2(x)])


class BernoulliGramacy2016(NoisyGramacy2016):
    """:class:`NoisyGramacy2016` observed sample by sample, as the Monte Carlo evaluator
    observes a design: sample ``i`` of every design succeeds when ``u_i < p(x)``, ``u_i``
    the i-th uniform of ``numpy.random.default_rng(noise_seed)`` (common random numbers:
    the same draws for every design).  ``evaluate(x)`` rests on all N samples;
    ``evaluate(x, rule)`` draws them in index order until ``rule`` (an
    :class:`~optimizer.sequential.SequentialRule`) decides, and ``info["samples"]`` says
    how many the estimate rests on.
    """

    name = "bernoulli_gramacy2016"

    def __init__(self, n_samples: int = 100, p_min: float = 0.98, s: float = 0.1,
                 noise_seed: int = 0):
        super().__init__(n_samples, p_min, s, noise_seed)
        self._u = np.random.default_rng(noise_seed).random(n_samples)

    def successes(self, x) -> np.ndarray:
        """Success of samples 0..N-1 of design ``x`` (bool array)."""
        return self._u < self.success_probability(x)

    def evaluate(self, x, rule=None):
        x = np.asarray(x, dtype=float)
        ok = self.successes(x)
        m = len(ok) if rule is None else rule(ok)
        k = int(ok[:m].sum())
        value, var = binomial_observation(k, m)
        return self.objective(x), {"p_success": value}, {"p_success": var}, {
            "successes": k, "samples": m, "p_true": self.success_probability(x)}


@dataclass
class Estimate:
    """A :class:`~optimizer.problem.ReliabilityEstimate` of :class:`LatentDifficulty`."""

    successes: int
    n_samples: int
    base_seed: int
    p_success: float
    ci_low: float
    ci_high: float
    cp_low: float
    cp_high: float
    mass: float
    mean_completion_time: float = math.nan
    mean_completion_time_success: float = math.nan
    failures_by_reason: dict = field(default_factory=dict)
    key: str = ""
    reused: int = 0


class LatentDifficulty(TestProblem):
    """A chance-constrained problem with a known truth whose failures share samples as the
    simulator's do, as a :class:`~optimizer.problem.DesignProblem` for whole runs
    (:func:`optimizer.run.run_optimization` with Case 1).

    Design x in [0, 1]^2; objective ("mass") ``x1 + x2``, exact; success probability
    ``P_s(x) = Phi(-c1(x) / s)`` with the first constraint ``c1`` of
    :class:`Gramacy2016` (``s = 0.1``), known in closed form.  Sample ``i`` of base seed
    ``b`` draws one uniform ``u_i`` (``numpy.random.default_rng(b * 1_000_003 + i)``, the
    simulator's seed of that sample) and fails design x when ``u_i >= P_s(x)``: ``u_i``
    is the sample's difficulty, shared by every design, so designs near one another fail
    on the same samples (with common random numbers a design's observed P*_s is the
    empirical distribution function of the ``u_i`` at ``P_s(x)``, the same luck for all
    of them).  Feasible when ``P_s(x) >= p_min`` (default 0.98).

    ``dims`` > 2 adds variables x3.. that do not enter the objective but lower P_s away
    from 0.5: ``c1`` is raised by ``penalty * sum_k (x_k - 0.5)^2`` (as most of Case 1's
    variables act on P*_s and not on m_a).  Designs of almost one objective then differ
    in reliability, the near-copies of Case 1's edge; the optimum keeps x_k = 0.5.

    **An exploration fidelity with a stated discrepancy** (``fidelities``,
    :meth:`at_fidelity`; docs/cases/replication.md, "With the exploration fidelity").
    Sample ``i`` of design x at exploration fails when ``sqrt(1 - jitter^2) Phi^-1(u_i) +
    jitter e_i(x) >= Phi^-1(P_s(x)) + shift``.  ``e_i(x)`` is a standard normal of its own
    for each design and sample: the step's own flips, unrelated from design to design as
    the simulator's are.  ``jitter`` in [0, 1) sets how often a verdict differs from the
    reference's without moving P_s (the left side stays standard normal): 0.5 flips 16 %
    of the verdicts at P_s = 0.61, 9.6 % at 0.85, 1.9 % at 0.98 and 1.1 % at 0.99, near
    the rates measured between the simulator's 2 ms and 1 ms steps (17, 17, 2 and 0-1 %
    on designs of those P*_s, N = 100, docs/studies/fidelity.md).  ``shift`` biases it:
    > 0 optimistic (exploration sees a higher P_s than is true: P_s = 0.98 seen as 0.9907
    at +0.3), < 0 pessimistic (the first exploration form's -11 points at Case 2's
    optimum is about -1.1).  With both 0 the verdicts are the reference's; the estimates'
    key differs all the same.
    """

    name = "latent_difficulty"
    horizon = math.nan
    grid_points = 801

    fidelities = ("exploration",)

    def __init__(self, p_min: float = 0.98, s: float = 0.1, dims: int = 2,
                 penalty: float = 0.4, jitter: float = 0.5, shift: float = 0.0,
                 fidelity: str = "reference"):
        self.p_min, self.s = float(p_min), float(s)
        self.dims, self.penalty = int(dims), float(penalty)
        self.jitter, self.shift, self.fidelity = float(jitter), float(shift), str(fidelity)
        if self.dims < 2:
            raise ValueError(f"dims: got {dims!r}; must be >= 2")
        if not (math.isfinite(self.jitter) and 0.0 <= self.jitter < 1.0):
            raise ValueError(f"jitter: got {jitter!r}; must be in [0, 1) (the weight of a "
                             "verdict's own noise on the probit scale)")
        if not (math.isfinite(self.shift) and abs(self.shift) <= 3.0):
            raise ValueError(f"shift: got {shift!r}; must be in [-3, 3] (probit scale)")
        if self.fidelity not in ("reference",) + self.fidelities:
            raise ValueError(f"fidelity: got {fidelity!r}; must be 'reference' or one of "
                             f"{self.fidelities}")
        self.bounds = [(0.0, 1.0)] * self.dims
        self.variable_names = tuple(f"x{k + 1}" for k in range(self.dims))
        self.thresholds = {"p_success": self.p_min}
        self._u: dict[int, np.ndarray] = {}

    def _c(self, x) -> float:
        x = np.asarray(x, dtype=float)
        return float(_gramacy_c1(x[:2]) + self.penalty * np.sum((x[2:] - 0.5) ** 2))

    # --- the truth
    def objective(self, x) -> float:
        return float(x[0] + x[1])

    def success_probability(self, x) -> float:
        """True P_s(x)."""
        return float(norm.cdf(-self._c(x) / self.s))

    def true_constraints(self, x):
        return {"p_success": self.success_probability(x)}

    def reference_optimum(self):
        """The optimum of the first two variables (the grid and polish of
        :class:`TestProblem`), the others at 0.5."""
        if self.dims == 2:
            return super().reference_optimum()
        x, f = LatentDifficulty(self.p_min, self.s).reference_optimum()
        return np.concatenate([x, np.full(self.dims - 2, 0.5)]), f

    def _grid_values(self, X):
        return X.sum(1), _gramacy_c1(X) <= -self.s * norm.ppf(self.p_min)

    def _slsqp_constraints(self, x):
        return np.array([-self.s * norm.ppf(self.p_min) - _gramacy_c1(np.asarray(x, float))])

    def optimum(self, p_min: float) -> float:
        """The least objective of a design with P_s >= ``p_min`` (computed)."""
        return LatentDifficulty(p_min, self.s).reference_optimum()[1]

    def at_fidelity(self, name: str) -> LatentDifficulty:
        """The same problem evaluated at fidelity ``name`` ("reference": the truth's
        verdicts; "exploration": the discrepancy of the class docstring)."""
        return LatentDifficulty(self.p_min, self.s, self.dims, self.penalty,
                                self.jitter, self.shift, name)

    def jitters(self, x, base_seed: int, n: int) -> np.ndarray:
        """e_0..e_{n-1}(x) of ``base_seed``: standard normals drawn in sample order from a
        stream of the design's own (a longer draw starts with a shorter one)."""
        digest = zlib.crc32(np.asarray(x, dtype=np.float64).tobytes())
        return np.random.default_rng([int(base_seed), digest, 7]).standard_normal(int(n))

    # --- the DesignProblem
    def mass(self, x) -> float:
        return self.objective(x)

    def difficulties(self, base_seed: int, n: int) -> np.ndarray:
        """u_0..u_{n-1} of ``base_seed``."""
        u = self._u.get(base_seed, np.zeros(0))
        if len(u) < n:
            more = [np.random.default_rng(base_seed * 1_000_003 + i).random()
                    for i in range(len(u), n)]
            u = self._u[base_seed] = np.concatenate([u, more])
        return u[:n]

    def evaluate(self, x, n_samples=None, base_seed=0, *, stop=None, results_path=None,
                 label="", progress=None):
        if n_samples is None:          # TestProblem.evaluate: the noise-free observation
            return super().evaluate(x)
        x = np.asarray(x, dtype=float)
        u = self.difficulties(int(base_seed), int(n_samples))
        p = self.success_probability(x)
        if self.fidelity == "reference":
            ok = u < p
        else:
            z = (math.sqrt(1.0 - self.jitter ** 2) * norm.ppf(u)
                 + self.jitter * self.jitters(x, base_seed, n_samples))
            ok = z < norm.ppf(p) + self.shift
        m = len(ok) if stop is None else (stop(ok.tolist()) or len(ok))
        k = int(ok[:m].sum())
        lo, hi = wilson_interval(k, m)
        cp_lo = 0.0 if k == 0 else float(beta.ppf(0.025, k, m - k + 1))
        cp_hi = 1.0 if k == m else float(beta.ppf(0.975, k + 1, m - k))
        if progress is not None:
            progress(m, m)
        return Estimate(successes=k, n_samples=m, base_seed=int(base_seed), p_success=k / m,
                        ci_low=lo, ci_high=hi, cp_low=cp_lo, cp_high=cp_hi,
                        mass=self.objective(x),
                        failures_by_reason={"u_i >= P_s(x)": m - k} if m > k else {},
                        key=f"{self.name}{self._key_tag()}:{x.tolist()}")

    def _key_tag(self) -> str:
        return ("" if self.fidelity == "reference"
                else f"@{self.fidelity}(jitter={self.jitter!r},shift={self.shift!r})")

    def design_dict(self, x) -> dict:
        return {n: float(v) for n, v in zip(self.variable_names, x)}

    def reference_design(self, name):
        return None

    def published_outcome(self, name):
        return None

    def settings(self) -> dict:
        out = {"problem": self.name, "p_min": self.p_min, "s": self.s,
               "model_version": self.name}
        if self.dims > 2:
            out.update(dims=self.dims, penalty=self.penalty)
        if self.fidelity != "reference":
            out.update(fidelity=self.fidelity, jitter=self.jitter, shift=self.shift)
        return out

    def describe(self) -> str:
        return f"{self.name} test problem (in-process)"


PROBLEMS = {p.name: p for p in (Gardner2014, Gramacy2016, NoisyGramacy2016,
                                BernoulliGramacy2016, LatentDifficulty)}
