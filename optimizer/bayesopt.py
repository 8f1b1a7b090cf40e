"""Reliability-constrained Bayesian optimisation over a box (SPEC section 7).

Simulator-independent: the expensive function is any callable. The optimiser minimises an
objective ``f(x)`` over a box subject to

* **coupled (modelled) constraints** ``g_j(x) >= threshold_j``, observed together with
  the objective, possibly noisily (e.g. a success probability estimated from N Monte Carlo
  samples), each modelled by its own Gaussian process; and
* an optional **cheap deterministic constraint** ``cheap_constraint(x) -> bool`` (e.g. the
  system mass ``m_a(x) <= 15 kg``) that simply excludes points: points failing it are never
  proposed, so the expensive function never sees them.

Surrogates (scikit-optimize parts): one :class:`skopt.learning.GaussianProcessRegressor`
per modelled quantity with kernel ``ConstantKernel * Matern(nu=2.5, one length scale per
variable) + WhiteKernel`` (noise level fitted by maximum likelihood; it is excluded from
the latent predictions). Inputs are normalised to the unit cube, outputs standardised to
zero mean / unit standard deviation before fitting. Hyperparameter fits are deterministic
given the data (fixed ``random_state`` derived from ``seed`` and the number of
observations, fixed number of restarts).

Known observation noise: a coupled constraint observation may come with a known variance
(in the constraint's own units). It is added to the diagonal of that GP's kernel matrix
(the ``alpha`` array of the regressor), on top of the fitted white noise, which then only
absorbs model misfit. For a success probability estimated as ``k/N`` use
:func:`binomial_observation`.

Acquisition (all quantities in standardised units of the objective GP):

* before any evaluated point is observed feasible: the posterior probability that every
  coupled constraint is satisfied, ``PF(x) = prod_j Phi((mu_j(x) - t_j) / s_j(x))``
  (latent posterior, i.e. without observation noise);
* afterwards: ``EI(x) * PF(x)`` where EI is the expected improvement over the incumbent
  ``mu* = min`` of the objective posterior mean over the (active-set) points whose
  observation was feasible. The logarithm of the acquisition is maximised (numerically
  robust when EI or PF underflow).
* expected-improvement-plus (MATLAB ``bayesopt`` semantics, ExplorationRatio default 0.5):
  once a feasible incumbent exists, if the maximiser ``x*`` has objective posterior
  standard deviation ``s(x*) < ratio * sigma_noise`` (fitted noise standard deviation), the
  optimiser is over-exploiting: the objective GP's signal variance is multiplied by the
  number of evaluations so far (``n``) and the acquisition re-maximised; if still
  over-exploiting, the factor becomes ``10 n``, ``100 n``, ... up to 5 tries in all. The
  original GP is used again afterwards (the modified one is a temporary copy).

Acquisition maximisation: ``n_candidates`` uniform random points of the unit cube plus
Gaussian perturbations of the best observed points, those failing the cheap constraint
removed; the best ``n_polish`` are polished with L-BFGS-B (analytic gradient of the log
acquisition; bounds = box; a polished point that fails the cheap constraint is
discarded).

Active set: when more than ``active_set`` observations exist, GPs are fitted on a
deterministic subset: the ``active_set // 4`` observed-feasible points with the lowest
objective (ties: earlier first), then the most recent observations until ``active_set``
points are chosen.

Reproducibility / checkpointing: all randomness comes from the optimiser's own
``numpy.random.Generator`` (PCG64), whose state is part of :meth:`state_dict`. A state
saved after :meth:`ConstrainedBayesOpt.tell` and restored with
:meth:`ConstrainedBayesOpt.from_state_dict` produces exactly the same subsequent asks
(bit for bit, same platform / library versions) as the uninterrupted optimiser.
"""

from __future__ import annotations

import json
import math
import os
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np
from scipy.linalg import solve_triangular
from scipy.optimize import minimize as _scipy_minimize
from scipy.spatial.distance import cdist
from scipy.special import erfcx, log_ndtr, ndtr
from skopt.learning import GaussianProcessRegressor
from skopt.learning.gaussian_process.kernels import ConstantKernel, Matern, WhiteKernel
from skopt.sampler import Sobol
from skopt.space import Space

from .checkpoint import CheckpointError, load_checkpoint, save_checkpoint

__all__ = [
    "Observation",
    "ConstrainedBayesOpt",
    "OptimizeResult",
    "minimize",
    "binomial_observation",
    "expected_improvement_plus",
]

_LOG_ACQ_FLOOR = -1.0e6  # finite floor for log-acquisition values (keeps L-BFGS-B sane)
_STATE_KIND = "ConstrainedBayesOpt"


# --------------------------------------------------------------------------- helpers
def binomial_observation(successes: int, trials: int) -> tuple[float, float]:
    """Value and observation variance of a success probability estimated from trials.

    Returns ``(k/N, p_adj (1 - p_adj) / N)`` with the Laplace-smoothed ``p_adj =
    (k + 1) / (N + 2)`` (posterior mean under a uniform prior, the Agresti-Coull idea
    with one pseudo-success and one pseudo-failure). The plain plug-in variance
    ``p(1-p)/N`` would claim zero noise at ``k = N`` (or ``k = 0``), which is exactly
    where a reliability constraint ``P_s >= 0.98`` is decided; the smoothed value keeps a
    principled floor (``N = 100``, ``k = 100``: std 0.0098, about one
    success in ``N``), and equals the plug-in variance to within ``O(1/N)`` elsewhere
    (``k = 98``: std 0.0149 versus 0.0140).
    """
    k, n = int(successes), int(trials)
    if n <= 0 or not 0 <= k <= n:
        raise ValueError(f"need 0 <= successes <= trials and trials > 0, got {k}/{n}")
    p_adj = (k + 1.0) / (n + 2.0)
    return k / n, p_adj * (1.0 - p_adj) / n


def _jsonable(obj: Any) -> Any:
    """Convert numpy scalars/arrays (recursively) to plain Python for JSON."""
    if isinstance(obj, Mapping):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist())
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.floating):
        return float(obj)
    return obj


@dataclass
class Observation:
    """One evaluated design.

    Attributes:
        x: design in the problem's own units, shape ``(d,)``.
        objective: objective value (to be minimised), own units.
        constraints: coupled constraint values by name (feasible if value >= threshold).
        constraint_variances: known observation variance of each constraint value (units
            squared); a constraint absent here has unknown noise (fitted by its GP).
        feasible: every observed constraint value met its threshold.
        info: free-form JSON-serialisable data returned by the evaluated function.
        acquisition: how the optimiser chose ``x`` (phase, acquisition value, EI+ tries,
            model predictions); empty if ``x`` was not produced by :meth:`ask`.
    """

    x: np.ndarray
    objective: float
    constraints: dict[str, float]
    constraint_variances: dict[str, float]
    feasible: bool
    info: dict = field(default_factory=dict)
    acquisition: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {
            "x": [float(v) for v in self.x],
            "objective": float(self.objective),
            "constraints": {k: float(v) for k, v in self.constraints.items()},
            "constraint_variances": {k: float(v) for k, v in self.constraint_variances.items()},
            "feasible": bool(self.feasible),
            "info": _jsonable(self.info),
            "acquisition": _jsonable(self.acquisition),
        }

    @classmethod
    def from_dict(cls, d: Mapping) -> "Observation":
        return cls(
            x=np.asarray(d["x"], dtype=float),
            objective=float(d["objective"]),
            constraints={k: float(v) for k, v in d["constraints"].items()},
            constraint_variances={k: float(v) for k, v in d["constraint_variances"].items()},
            feasible=bool(d["feasible"]),
            info=dict(d.get("info", {})),
            acquisition=dict(d.get("acquisition", {})),
        )


class _GP:
    """A fitted GP on standardised outputs with fast latent predictions.

    ``predict(U)`` returns the latent posterior mean and standard deviation in
    standardised units at unit-cube points ``U`` (shape ``(m, d)``); the white noise is
    excluded. ``noise_sd`` is the fitted white-noise standard deviation (standardised).
    """

    def __init__(self, U, y, var=None, *, random_state: int, n_restarts: int, kernel=None):
        y = np.asarray(y, dtype=float)
        self.y_mean = float(np.mean(y))
        sd = float(np.std(y))
        self.y_std = sd if sd > 1e-12 * max(1.0, abs(self.y_mean)) else 1.0
        ys = (y - self.y_mean) / self.y_std
        d = U.shape[1]
        if kernel is None:
            kernel = ConstantKernel(1.0, (1e-3, 1e3)) * Matern(
                length_scale=np.full(d, 0.3), length_scale_bounds=(1e-2, 1e2), nu=2.5
            ) + WhiteKernel(1e-2, (1e-6, 1.0))
            optimizer = "fmin_l_bfgs_b"
        else:
            optimizer = None
        alpha = np.full(len(y), 1e-10)
        if var is not None:
            alpha = alpha + np.asarray(var, dtype=float) / self.y_std**2
        self._fit_args = (U, y, var)
        last_exc = None
        for jitter in (0.0, 1e-8, 1e-6, 1e-4):
            gp = GaussianProcessRegressor(
                kernel=kernel,
                alpha=alpha + jitter,
                optimizer=optimizer,
                n_restarts_optimizer=n_restarts if optimizer else 0,
                normalize_y=False,
                noise="gaussian",
                random_state=random_state,
            )
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    gp.fit(U, ys)
                break
            except (np.linalg.LinAlgError, ValueError) as exc:  # pragma: no cover - rare
                last_exc = exc
        else:  # pragma: no cover
            raise RuntimeError(f"GP fit failed: {last_exc}") from last_exc
        self.gp = gp
        self.noise_sd = math.sqrt(float(gp.noise_ or 0.0))
        self._alpha = alpha
        self._random_state = random_state

    def _cache(self):
        gp = self.gp
        k = gp.kernel_  # Sum(Product(Constant, Matern(nu=2.5)), White(0))
        self._c = float(k.k1.k1.constant_value)
        self._ls = np.broadcast_to(np.asarray(k.k1.k2.length_scale, dtype=float),
                                   (gp.X_train_.shape[1],)).copy()
        self._Xs = gp.X_train_ / self._ls

    def predict(self, U, grad: bool = False):
        """Latent posterior mean and std (standardised units) at unit-cube points ``U``
        (``(m, d)``). With ``grad`` also their gradients with respect to ``U``
        (``(m, d)`` each). Matern-5/2 evaluated directly (same hyperparameters as the
        fitted kernel) for speed."""
        if not hasattr(self, "_c"):
            self._cache()
        U = np.atleast_2d(np.asarray(U, dtype=float))
        gp, c = self.gp, self._c
        if grad:
            D = U[:, None, :] / self._ls - self._Xs[None, :, :]  # (m, n, d) scaled differences
            r = np.sqrt(np.einsum("mnd,mnd->mn", D, D))
        else:
            r = cdist(U / self._ls, self._Xs)
        s5r = math.sqrt(5.0) * r
        e = np.exp(-s5r)
        K = c * (1.0 + s5r + (5.0 / 3.0) * r**2) * e
        mu = K @ gp.alpha_
        v = solve_triangular(gp.L_, K.T, lower=True, check_finite=False)  # (n, m)
        var = np.maximum(c - np.einsum("nm,nm->m", v, v), 0.0)
        sd = np.sqrt(var)
        if not grad:
            return mu, sd
        # dK/du = -5c/3 (1 + sqrt5 r) exp(-sqrt5 r) (u - x) / l^2
        dK = (-(5.0 / 3.0) * c * (1.0 + s5r) * e)[:, :, None] * (D / self._ls)  # (m, n, d)
        dmu = np.einsum("mnd,n->md", dK, gp.alpha_)
        w = solve_triangular(gp.L_.T, v, lower=False, check_finite=False)  # K^-1 k, (n, m)
        dvar = -2.0 * np.einsum("nm,mnd->md", w, dK)
        with np.errstate(divide="ignore", invalid="ignore"):
            dsd = np.where(sd[:, None] > 1e-12, dvar / (2.0 * sd[:, None]), 0.0)
        return mu, sd, dmu, dsd

    def with_signal_variance_scaled(self, factor: float) -> "_GP":
        """Copy with the signal (constant-kernel) variance multiplied by ``factor``;
        length scales and noise are kept fixed, data and standardisation unchanged."""
        k = self.gp.kernel_  # Sum(Product(Constant, Matern), White(0))
        const, matern = k.k1.k1, k.k1.k2
        kernel = ConstantKernel(const.constant_value * factor, "fixed") * Matern(
            matern.length_scale, "fixed", nu=matern.nu
        ) + WhiteKernel(max(self.noise_sd**2, 1e-12), "fixed")
        new = _GP.__new__(_GP)
        U, y, var = self._fit_args
        gp = GaussianProcessRegressor(
            kernel=kernel, alpha=self._alpha, optimizer=None, normalize_y=False,
            noise="gaussian", random_state=self._random_state,
        )
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            gp.fit(U, (y - self.y_mean) / self.y_std)
        new.gp, new.y_mean, new.y_std = gp, self.y_mean, self.y_std
        new.noise_sd, new._alpha, new._random_state = self.noise_sd, self._alpha, self._random_state
        new._fit_args = self._fit_args
        return new


_LOG_SQRT_2PI = 0.5 * math.log(2.0 * math.pi)


def _log_ei(improvement, sd, grad: bool = False):
    """log of expected improvement ``E[max(improvement + sd*Z, 0)] = sd * tau(z)``,
    ``z = improvement / sd``, ``tau(z) = z Phi(z) + phi(z)``.

    Numerically stable for very negative z: there ``tau = phi(z) (1 + z R(z))`` with the
    Mills ratio ``R = Phi/phi = sqrt(pi/2) erfcx(-z/sqrt2)`` (relative error ~1e-16 z^2),
    and the asymptotic ``phi(z)/z^2 (1 - 3/z^2 + 15/z^4)`` below z = -1e3. With ``grad``
    also returns ``(d/d improvement, d/d sd)`` of the log (``Phi(z)/EI`` and
    ``phi(z)/EI``).
    """
    sd = np.maximum(sd, 1e-12)
    z = np.asarray(improvement / sd, dtype=float)
    log_phi = -0.5 * z**2 - _LOG_SQRT_2PI
    log_tau = np.empty_like(z)
    pos = z >= 0.0
    mid = (~pos) & (z > -1e3)
    far = z <= -1e3
    zp = z[pos]
    log_tau[pos] = np.log(zp * ndtr(zp) + np.exp(log_phi[pos]))
    zm = z[mid]
    R = math.sqrt(math.pi / 2.0) * erfcx(-zm / math.sqrt(2.0))
    log_tau[mid] = log_phi[mid] + np.log(np.maximum(1.0 + zm * R, 1e-300))
    zf = z[far]
    log_tau[far] = log_phi[far] - 2.0 * np.log(-zf) + np.log1p(-3.0 / zf**2 + 15.0 / zf**4)
    val = log_tau + np.log(sd)
    if not grad:
        return val
    d_imp = np.exp(log_ndtr(z) - log_tau) / sd
    d_sd = np.exp(log_phi - log_tau) / sd
    return val, d_imp, d_sd


def expected_improvement_plus(maximise: Callable, model, n_evaluations: int,
                              exploration_ratio: float = 0.5, max_tries: int = 5):
    """Expected-improvement-plus safeguard (MATLAB ``bayesopt`` semantics).

    Args:
        maximise: ``maximise(model) -> x`` returns the acquisition maximiser computed
            with the given objective model.
        model: objective surrogate with ``predict(X) -> (mean, std)`` (latent std),
            attribute ``noise_sd`` and ``with_signal_variance_scaled(factor)``.
        n_evaluations: number of evaluations so far (first variance factor).
        exploration_ratio: over-exploiting when ``std(x) < ratio * noise_sd``.
        max_tries: the most modified re-maximisations (factors n, 10n, 100n, ...).

    Returns ``(x, tries, factors)``: the chosen point, how many re-maximisations were
    made and with which signal-variance factors. ``model`` itself is never modified.
    """
    x = maximise(model)
    factors: list[float] = []
    current = model
    while len(factors) < max_tries:
        sd = float(current.predict(np.atleast_2d(x))[1][0])
        if not sd < exploration_ratio * model.noise_sd:
            break
        factor = float(max(n_evaluations, 1)) * 10.0 ** len(factors)
        factors.append(factor)
        current = model.with_signal_variance_scaled(factor)
        x = maximise(current)
    return x, len(factors), factors


# --------------------------------------------------------------------------- optimiser
#: two designs closer than this in every normalised coordinate count as the same design
DUPLICATE_TOL = 1e-3


def _near_any(points: np.ndarray, others: np.ndarray, tol: float) -> np.ndarray:
    """For each row of ``points`` (unit cube), whether some row of ``others`` lies within
    ``tol`` of it in every coordinate."""
    if len(others) == 0:
        return np.zeros(len(points), dtype=bool)
    return (np.abs(points[:, None, :] - others[None, :, :]).max(axis=2) < tol).any(axis=1)


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
    """

    def __init__(self, bounds: Sequence[Sequence[float]], constraints: Mapping[str, float],
                 cheap_constraint: Callable[[np.ndarray], bool] | None = None, *,
                 n_initial: int = 50, n_iterations: int = 200, active_set: int = 200,
                 exploration_ratio: float = 0.5, seed: int = 0,
                 n_candidates: int | None = None, n_polish: int = 5,
                 n_restarts_gp: int = 2, max_eiplus_tries: int = 5):
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

    def _fit_models(self, idx, objective: bool = True):
        H = [self.history[i] for i in idx]
        U = self.to_unit(np.array([o.x for o in H]))
        rs = (self.seed * 7919 + len(self.history) * 31) % (2**31 - 1)
        obj = (_GP(U, [o.objective for o in H], random_state=rs, n_restarts=self.n_restarts_gp)
               if objective else None)
        cons = {}
        for j, name in enumerate(self.constraints):
            var = np.array([o.constraint_variances.get(name, 0.0) for o in H])
            cons[name] = _GP(U, [o.constraints[name] for o in H], var if np.any(var > 0) else None,
                             random_state=(rs + 104729 * (j + 1)) % (2**31 - 1),
                             n_restarts=self.n_restarts_gp)
        return U, H, obj, cons

    # ------------------------------------------------------------------ acquisition
    def _log_pf(self, cons: dict, U, grad: bool = False):
        U = np.atleast_2d(U)
        out = np.zeros(len(U))
        g = np.zeros(U.shape)
        for name, m in cons.items():
            t = (self.constraints[name] - m.y_mean) / m.y_std
            if grad:
                mu, sd, dmu, dsd = m.predict(U, grad=True)
            else:
                mu, sd = m.predict(U)
            sd_f = np.maximum(sd, 1e-12)
            w = (mu - t) / sd_f
            lp = log_ndtr(w)
            out += lp
            if grad:
                lam = np.exp(-0.5 * w**2 - 0.5 * math.log(2 * math.pi) - lp)  # phi/Phi
                g += lam[:, None] * (dmu - w[:, None] * dsd) / sd_f[:, None]
        return (out, g) if grad else out

    def _log_acq(self, obj: _GP | None, cons: dict, incumbent: float | None, U,
                 grad: bool = False):
        """log acquisition at unit-cube points (floored at a large negative value)."""
        if grad:
            val, g = self._log_pf(cons, U, grad=True)
        else:
            val = self._log_pf(cons, U)
        if incumbent is not None:
            if grad:
                mu, sd, dmu, dsd = obj.predict(U, grad=True)
                le, d_imp, d_sd = _log_ei(incumbent - mu, sd, grad=True)
                g = g - d_imp[:, None] * dmu + d_sd[:, None] * dsd
            else:
                mu, sd = obj.predict(U)
                le = _log_ei(incumbent - mu, sd)
            val = val + le
        val = np.nan_to_num(val, nan=_LOG_ACQ_FLOOR)
        if not grad:
            return np.maximum(val, _LOG_ACQ_FLOOR)
        floored = val <= _LOG_ACQ_FLOOR
        g = np.where(floored[:, None] | ~np.isfinite(g), 0.0, g)
        return np.maximum(val, _LOG_ACQ_FLOOR), g

    def _maximise(self, obj, cons, incumbent, cand, cand_acq=None):
        """Best point of ``cand`` (unit cube) polished by L-BFGS-B (analytic gradient);
        returns (u, log_acq)."""
        if cand_acq is None:
            cand_acq = self._log_acq(obj, cons, incumbent, cand)
        order = np.argsort(-cand_acq, kind="stable")
        best_u, best_v = cand[order[0]].copy(), float(cand_acq[order[0]])

        def f(u):
            v, g = self._log_acq(obj, cons, incumbent, u[None, :], grad=True)
            return -float(v[0]), -g[0]

        for i in order[: self.n_polish]:
            res = _scipy_minimize(f, cand[i], jac=True, method="L-BFGS-B",
                                  bounds=[(0.0, 1.0)] * self.dim, options={"maxiter": 100})
            u = np.clip(res.x, 0.0, 1.0)
            v = float(self._log_acq(obj, cons, incumbent, u[None, :])[0])
            if v > best_v and self._cheap_ok(u)[0]:
                best_u, best_v = u, v
        return best_u, best_v

    def ask(self) -> np.ndarray:
        """Next design to evaluate (problem units, shape ``(d,)``).

        Call :meth:`tell` with its result before asking again: a repeated ask in the
        model-based phase draws fresh candidates and may return a different point.
        Diagnostics of the choice are left in :attr:`last_ask_info`.
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
        # candidates: uniform + local perturbations of the best observed points
        rng = self._rng
        cand = rng.random((self.n_candidates, self.dim))
        if incumbent is not None:
            fi = np.flatnonzero(feas)
            centres = U[fi[np.argsort([H[i].objective for i in fi], kind="stable")[:5]]]
        else:
            lp = self._log_pf(cons, U)
            centres = U[np.argsort(-lp, kind="stable")[:5]]
        n_loc = max(self.n_candidates // 4, 1)
        scales = np.array([0.01, 0.05, 0.15])[np.arange(n_loc) % 3][:, None]
        local = centres[np.arange(n_loc) % len(centres)] + scales * rng.standard_normal((n_loc, self.dim))
        cand = np.vstack([cand, np.clip(local, 0.0, 1.0)])
        cand = cand[self._cheap_ok(cand)]
        if len(cand) == 0:
            raise RuntimeError("no acquisition candidate satisfies cheap_constraint")

        tries, factors = 0, []
        if incumbent is None:
            u, la = self._maximise(None, cons, None, cand)
            phase = "feasibility"
        else:
            phase = "ei"
            base_acq = self._log_acq(obj, cons, incumbent, cand)

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
            la = float(self._log_acq(obj, cons, incumbent, u[None, :])[0])
        # Never ask for a design already evaluated: with common random numbers a repeat
        # returns the same observation, so it teaches the models nothing (a flat
        # feasibility model, e.g. every P*_s observed 0, otherwise sends the polish to
        # the same corner again and again).  Take the best candidate away from them.
        deduplicated = False
        U_all = self.to_unit(np.array([o.x for o in self.history]))
        if _near_any(u[None, :], U_all, DUPLICATE_TOL)[0]:
            fresh = cand[~_near_any(cand, U_all, DUPLICATE_TOL)]
            if len(fresh):
                score = (self._log_pf(cons, fresh) if incumbent is None
                         else self._log_acq(obj, cons, incumbent, fresh))
                u = fresh[int(np.argmax(score))]
                la = float(score.max())
                deduplicated = True
        mu, sd = obj.predict(u[None, :])
        self.last_ask_info = {
            "deduplicated": deduplicated,
            "phase": phase,
            "log_acquisition": float(la),
            "probability_feasible": float(np.exp(self._log_pf(cons, u[None, :])[0])),
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
        info = _jsonable(dict(info or {}))
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
        winner should be validated with a larger fresh sample (SPEC: 1000 samples).
        """
        cand = [i for i, o in enumerate(self.history) if o.feasible]
        if not cand:
            return None
        if min_probability is not None and self.constraints:
            _, _, _, cons = self._fit_models(self._active_indices(), objective=False)
            U = self.to_unit(np.array([self.history[i].x for i in cand]))
            pf = np.exp(self._log_pf(cons, U))
            cand = [i for i, p in zip(cand, pf) if p >= min_probability]
            if not cand:
                return None
        return min((self.history[i] for i in cand), key=lambda o: o.objective)

    # ------------------------------------------------------------------ state
    def _settings(self) -> dict:
        return {
            "n_initial": self.n_initial, "n_iterations": self.n_iterations,
            "active_set": self.active_set, "exploration_ratio": self.exploration_ratio,
            "seed": self.seed, "n_candidates": self.n_candidates, "n_polish": self.n_polish,
            "n_restarts_gp": self.n_restarts_gp, "max_eiplus_tries": self.max_eiplus_tries,
        }

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
            "rng_state": _jsonable(self._rng.bit_generator.state),
            "initial_design": self._initial_design.tolist(),
            "history": [o.to_dict() for o in self.history],
        }

    @classmethod
    def from_state_dict(cls, state: Mapping, cheap_constraint=None, **overrides) -> "ConstrainedBayesOpt":
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
        self._rng = np.random.default_rng()
        self._rng.bit_generator.state = state["rng_state"]
        self._initial_design = np.asarray(state["initial_design"], dtype=float)
        self.history = [Observation.from_dict(o) for o in state["history"]]
        self.last_ask_info, self._last_ask_x = {}, None
        return self


# --------------------------------------------------------------------------- driver
@dataclass
class OptimizeResult:
    """Result of :func:`minimize`.

    ``best``: best observed-feasible observation (or None); ``history``: all
    observations in evaluation order; ``optimizer``: the optimiser (for further asks);
    ``stopped_by_callback``: the callback ended the run early.
    """

    best: Observation | None
    history: list[Observation]
    optimizer: ConstrainedBayesOpt
    stopped_by_callback: bool = False


def _unpack(out):
    if not isinstance(out, tuple) or not 2 <= len(out) <= 4:
        raise TypeError("fun must return (objective, constraints[, variances[, info]])")
    out = tuple(out) + (None,) * (4 - len(out))
    return out


def minimize(fun: Callable, bounds, constraints: Mapping[str, float], *,
             cheap_constraint=None, n_initial: int = 50, n_iterations: int = 200,
             checkpoint_path: str | os.PathLike | None = None, resume: bool = False,
             callback: Callable[[Observation, ConstrainedBayesOpt], Any] | None = None,
             **options) -> OptimizeResult:
    """Minimise ``fun`` over ``bounds`` subject to coupled and cheap constraints.

    Args:
        fun: ``fun(x) -> (objective, constraints, variances, info)`` with ``x`` in
            problem units; ``constraints`` a dict ``name -> value`` (feasible if
            ``value >= threshold``), ``variances`` a dict of known observation variances
            or None, ``info`` a JSON-serialisable dict or None (the last two optional).
        bounds, constraints, cheap_constraint, n_initial, n_iterations, options: see
            :class:`ConstrainedBayesOpt`.
        checkpoint_path: JSON checkpoint, written atomically after every evaluation.
        resume: continue from ``checkpoint_path`` if it exists (history replayed into the
            optimiser without re-evaluation; at most the evaluation in flight is lost).
            Bounds, constraints and settings must match the checkpoint; ``n_iterations``
            may differ (budget extension). Without ``resume`` an existing checkpoint is an
            error (never silently overwritten).
        callback: ``callback(observation, optimizer)`` after every evaluation and
            checkpoint; a truthy return value stops the run.

    Exceptions raised by ``fun`` propagate; the checkpoint then holds every completed
    evaluation.
    """
    opt = ConstrainedBayesOpt(bounds, constraints, cheap_constraint, n_initial=n_initial,
                              n_iterations=n_iterations, **options)
    if checkpoint_path is not None and Path(checkpoint_path).exists():
        if not resume:
            raise FileExistsError(f"checkpoint {str(checkpoint_path)!r} exists; pass resume=True "
                                  "to continue it or remove it to start afresh")
        state = load_checkpoint(checkpoint_path)
        try:
            saved = state["optimizer"]
            fresh = opt.state_dict()
            for key in ("bounds", "constraints", "has_cheap_constraint"):
                if saved[key] != fresh[key]:
                    raise ValueError(f"checkpoint {key} {saved[key]!r} differ from the requested "
                                     f"{fresh[key]!r}")
            for key, val in fresh["settings"].items():
                if key != "n_iterations" and saved["settings"][key] != val:
                    raise ValueError(f"checkpoint setting {key}={saved['settings'][key]!r} differs "
                                     f"from the requested {val!r}")
            opt = ConstrainedBayesOpt.from_state_dict(saved, cheap_constraint,
                                                      n_iterations=n_iterations)
        except (KeyError, TypeError) as exc:
            raise CheckpointError(f"checkpoint file {str(checkpoint_path)!r} lacks optimiser "
                                  f"state ({exc!r})") from exc
    stopped = False
    while not opt.done:
        x = opt.ask()
        objective, cons, var, info = _unpack(fun(x.copy()))
        obs = opt.tell(x, objective, cons, var, info)
        if checkpoint_path is not None:
            save_checkpoint(checkpoint_path, {"optimizer": opt.state_dict()})
        if callback is not None and callback(obs, opt):
            stopped = True
            break
    return OptimizeResult(best=opt.best_feasible(), history=list(opt.history), optimizer=opt,
                          stopped_by_callback=stopped)
