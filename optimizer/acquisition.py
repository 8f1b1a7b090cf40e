"""The acquisition: what the next evaluation should maximise (all quantities in the
standardised units of the surrogates, :mod:`optimizer.gp`).

* before any evaluated point is observed feasible: the posterior probability that every
  coupled constraint is satisfied, ``PF(x) = prod_j Phi((mu_j(x) - t_j) / s_j(x))``
  (latent posterior, i.e. without observation noise);
* afterwards: ``EI(x) * PF(x)`` where EI is the expected improvement over the incumbent
  (the lowest objective posterior mean over the observed-feasible points).  The logarithm
  of the acquisition is maximised (numerically robust when EI or PF underflow).
* expected-improvement-plus (MATLAB ``bayesopt`` semantics, ExplorationRatio default 0.5):
  once a feasible incumbent exists, if the maximiser ``x*`` has objective posterior
  standard deviation ``s(x*) < ratio * sigma_noise`` (fitted noise standard deviation), the
  optimiser is over-exploiting: the objective GP's signal variance is multiplied by the
  number of evaluations so far (``n``) and the acquisition re-maximised; if still
  over-exploiting, the factor becomes ``10 n``, ``100 n``, ... up to 5 tries in all. The
  original GP is used again afterwards (the modified one is a temporary copy).

Maximisation (:func:`maximise_acquisition`): the best of the given candidates, the best
``n_polish`` of them polished with L-BFGS-B (analytic gradient of the log acquisition;
bounds = the unit cube; a polished point outside the allowed set is discarded).
"""
from __future__ import annotations

import math
from collections.abc import Callable, Mapping

import numpy as np
from scipy.optimize import minimize as scipy_minimize
from scipy.special import erfcx, log_ndtr, ndtr

__all__ = ["LOG_ACQ_FLOOR", "log_ei", "log_probability_feasible", "log_acquisition",
           "maximise_acquisition", "expected_improvement_plus"]

#: finite floor for log-acquisition values (keeps L-BFGS-B sane)
LOG_ACQ_FLOOR = -1.0e6

_LOG_SQRT_2PI = 0.5 * math.log(2.0 * math.pi)


def log_ei(improvement, sd, grad: bool = False):
    """log of expected improvement ``E[max(improvement + sd*Z, 0)] = sd * tau(z)``,
    ``z = improvement / sd``, ``tau(z) = z Phi(z) + phi(z)``.

    Numerically stable for very negative z: there ``tau = phi(z) (1 + z R(z))`` with the
    Mills ratio ``R = Phi/phi = sqrt(pi/2) erfcx(-z/sqrt2)`` (relative error ~1e-16 z^2),
    and the asymptotic ``phi(z)/z^2 (1 - 3/z^2 + 15/z^4)`` below z = -1e3. With ``grad``
    also returns ``(d/d improvement, d/d sd)`` of the log (``Phi(z)/EI`` and
    ``phi(z)/EI``); below z = -1e3 from the asymptotic ratios themselves, since a
    difference of logs there loses every digit once ``log phi(z)`` is huge (z ~ -1e12 when
    sd sits at its floor).
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
    d_imp = np.empty_like(z)
    d_sd = np.empty_like(z)
    near = ~far
    d_imp[near] = np.exp(log_ndtr(z[near]) - log_tau[near])
    d_sd[near] = np.exp(log_phi[near] - log_tau[near])
    # x = -z: Phi/phi = (1 - 1/x^2 + 3/x^4)/x and tau/phi = (1 - 3/x^2 + 15/x^4)/x^2
    x = -zf
    rest = 1.0 - 3.0 / x**2 + 15.0 / x**4
    d_imp[far] = x * (1.0 - 1.0 / x**2 + 3.0 / x**4) / rest
    d_sd[far] = x**2 / rest
    return val, d_imp / sd, d_sd / sd


def log_probability_feasible(models: Mapping, thresholds: Mapping[str, float], U,
                             grad: bool = False):
    """log PF at unit-cube points ``U`` (``(m, d)``): the sum over the constraint GPs
    ``models[name]`` of ``log Phi((mu - t) / s)`` with ``t`` the threshold in the model's
    standardised units.  With ``grad`` also its gradient with respect to ``U``."""
    U = np.atleast_2d(U)
    out = np.zeros(len(U))
    g = np.zeros(U.shape)
    for name, m in models.items():
        t = (thresholds[name] - m.y_mean) / m.y_std
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


def log_acquisition(objective_model, constraint_models: Mapping, thresholds: Mapping[str, float],
                    incumbent: float | None, U, grad: bool = False):
    """log acquisition at unit-cube points: log PF, plus log EI over ``incumbent`` when
    there is one; floored at :data:`LOG_ACQ_FLOOR`.  With ``grad`` also the gradient."""
    if grad:
        val, g = log_probability_feasible(constraint_models, thresholds, U, grad=True)
    else:
        val = log_probability_feasible(constraint_models, thresholds, U)
    if incumbent is not None:
        if grad:
            mu, sd, dmu, dsd = objective_model.predict(U, grad=True)
            le, d_imp, d_sd = log_ei(incumbent - mu, sd, grad=True)
            g = g - d_imp[:, None] * dmu + d_sd[:, None] * dsd
        else:
            mu, sd = objective_model.predict(U)
            le = log_ei(incumbent - mu, sd)
        val = val + le
    val = np.nan_to_num(val, nan=LOG_ACQ_FLOOR)
    if not grad:
        return np.maximum(val, LOG_ACQ_FLOOR)
    floored = val <= LOG_ACQ_FLOOR
    g = np.where(floored[:, None] | ~np.isfinite(g), 0.0, g)
    return np.maximum(val, LOG_ACQ_FLOOR), g


def maximise_acquisition(objective_model, constraint_models: Mapping,
                         thresholds: Mapping[str, float], incumbent: float | None, cand,
                         n_polish: int, allowed: Callable[[np.ndarray], np.ndarray],
                         cand_acq=None):
    """Best point of ``cand`` (unit cube, ``(m, d)``) polished by L-BFGS-B (analytic
    gradient); ``allowed(U)`` says which points may be chosen.  Returns (u, log_acq)."""
    def acq(U, grad=False):
        return log_acquisition(objective_model, constraint_models, thresholds, incumbent, U,
                               grad)

    if cand_acq is None:
        cand_acq = acq(cand)
    order = np.argsort(-cand_acq, kind="stable")
    best_u, best_v = cand[order[0]].copy(), float(cand_acq[order[0]])

    def f(u):
        v, g = acq(u[None, :], grad=True)
        return -float(v[0]), -g[0]

    dim = cand.shape[1]
    for i in order[:n_polish]:
        res = scipy_minimize(f, cand[i], jac=True, method="L-BFGS-B",
                             bounds=[(0.0, 1.0)] * dim, options={"maxiter": 100})
        u = np.clip(res.x, 0.0, 1.0)
        v = float(acq(u[None, :])[0])
        if v > best_v and allowed(u)[0]:
            best_u, best_v = u, v
    return best_u, best_v


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
