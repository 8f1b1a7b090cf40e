"""Tests of the constrained Bayesian optimiser (optimizer/, docs/optimizer.md).

Budgets and tolerances below were measured on the development machine (2 CPU cores);
the test problems' optima are recomputed numerically (optimizer.testproblems), never
quoted. GP hyperparameter fits use ``n_restarts_gp=0`` here to keep run times short (the
production default is 2 restarts).
"""

import json
import math
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from optimizer import (  # noqa: E402
    CheckpointError,
    ConstrainedBayesOpt,
    binomial_observation,
    expected_improvement_plus,
    minimize,
)
from optimizer.acquisition import log_acquisition, log_ei as _log_ei  # noqa: E402
from optimizer.testproblems import Gardner2014, Gramacy2016, NoisyGramacy2016  # noqa: E402

FAST = {"n_restarts_gp": 0}


def _run(problem, n_initial, n_iterations, seed=0, **kw):
    return minimize(problem.evaluate, problem.bounds, problem.thresholds,
                    cheap_constraint=problem.cheap_constraint, n_initial=n_initial,
                    n_iterations=n_iterations, seed=seed, **{**FAST, **kw})


# ----------------------------------------------------------------- reference optima
def test_reference_optima_match_known_values():
    x, f = Gramacy2016().reference_optimum()
    # Gramacy et al. (2016): f* ~ 0.5998 at (0.1954, 0.4044)
    assert f == pytest.approx(0.5998, abs=2e-4)
    assert np.allclose(x, [0.1954, 0.4044], atol=2e-3)
    x, f = Gardner2014().reference_optimum()
    # analytic: f >= -1 - 1 with equality only at x1 = 3 pi/2, x2 = 0 (feasible)
    assert f == pytest.approx(-2.0, abs=1e-9)
    assert np.allclose(x, [1.5 * math.pi, 0.0], atol=1e-4)
    prob = NoisyGramacy2016()
    x, f = prob.reference_optimum()
    assert prob.success_probability(x) == pytest.approx(0.98, abs=1e-6)
    assert f > 0.5998  # tighter constraint than the noise-free problem


# ----------------------------------------------------------------- convergence
def test_gardner2014_reaches_optimum():
    """Measured: seeds 0/1/2 within 0.02 of f* after 13/18/25 evaluations, ~5 s."""
    prob = Gardner2014()
    x_star, f_star = prob.reference_optimum()
    res = _run(prob, n_initial=10, n_iterations=20)
    assert res.best is not None
    assert res.best.objective - f_star <= 0.02
    assert np.linalg.norm(res.best.x - x_star) <= 0.1
    assert prob.is_feasible(res.best.x)


def test_gramacy2016_reaches_constrained_optimum():
    """Measured: seeds 0/1/2 within 0.01 of f* = 0.5998 after 20 evaluations, ~15 s."""
    prob = Gramacy2016()
    x_star, f_star = prob.reference_optimum()
    res = _run(prob, n_initial=10, n_iterations=20)
    assert res.best is not None
    assert prob.is_feasible(res.best.x)  # noise-free: observed feasible == truly feasible
    assert 0.0 <= res.best.objective - f_star <= 0.01
    assert np.linalg.norm(res.best.x - x_star) <= 0.02


@pytest.mark.slow
def test_noisy_reliability_constraint_ends_truly_feasible():
    """P_s from N = 100 Bernoulli samples, threshold 0.98 (docs/optimizer.md §2).

    Measured over seeds 0-6 (10 seed + 40 iterations): the plain best (observed P_s >=
    0.98) had true p >= 0.952 (winner's curse) and objective within -0.031/+0.004 of the
    true optimum; with the posterior filter (min_probability=0.8) true p >= 0.980 and
    objective gap <= 0.029. ~20 s per run.
    """
    prob = NoisyGramacy2016()
    _, f_star = prob.reference_optimum()
    res = _run(prob, n_initial=10, n_iterations=40)
    plain = res.best
    assert plain is not None and plain.constraints["p_success"] >= 0.98
    assert prob.success_probability(plain.x) >= 0.94
    assert -0.05 <= plain.objective - f_star <= 0.03
    robust = res.optimizer.best_feasible(min_probability=0.8)
    assert robust is not None
    assert prob.success_probability(robust.x) >= 0.975
    assert robust.objective - f_star <= 0.04
    # the cheap constraint (c2 <= 0) was never violated by an evaluated point
    assert all(prob.cheap_constraint(o.x) for o in res.history)


# ----------------------------------------------------------------- cheap constraint
def test_cheap_constraint_never_violated_by_evaluated_points():
    prob = Gramacy2016()
    calls = []

    def cheap(x):  # excludes the unconstrained optimum region (x1 ~ 0.195)
        calls.append(1)
        return bool(x[0] >= 0.3)

    def fun(x):
        assert cheap(x), f"expensive function called at excluded x={x}"
        return prob.evaluate(x)

    res = minimize(fun, prob.bounds, prob.thresholds, cheap_constraint=cheap,
                   n_initial=8, n_iterations=8, seed=1, **FAST)
    assert len(res.history) == 16
    assert all(o.x[0] >= 0.3 for o in res.history)
    assert len(calls) > 1000  # the acquisition search consulted it


def test_cheap_constraint_that_admits_nothing_is_an_error():
    with pytest.raises(ValueError, match="cheap_constraint"):
        ConstrainedBayesOpt([(0, 1), (0, 1)], {}, cheap_constraint=lambda x: False, n_initial=4)


def test_active_set_keeps_best_feasible_and_most_recent():
    opt = ConstrainedBayesOpt([(0, 1)], {"g": 0.0}, n_initial=1, active_set=20)
    rng = np.random.default_rng(0)
    for i in range(60):
        opt.tell([rng.random()], float(rng.random()), {"g": 1.0 if i % 2 else -1.0})
    idx = opt._active_indices()
    assert len(idx) == 20 and len(set(idx)) == 20
    feas = [i for i in range(60) if i % 2]
    best5 = sorted(feas, key=lambda i: opt.history[i].objective)[:5]
    assert set(best5) <= set(idx)
    assert set(range(60 - 15, 60)) <= set(idx)
    assert len(ConstrainedBayesOpt([(0, 1)], {}, n_initial=1)._active_indices()) == 0


# ----------------------------------------------------------------- EI+ safeguard
class _FakeModel:
    """Posterior std grows with sqrt(signal-variance factor), like a GP far from data."""

    def __init__(self, base_sd, factor=1.0, log=None):
        self.base_sd, self.factor, self.noise_sd = base_sd, factor, 1.0
        self.log = log if log is not None else []

    def predict(self, X):
        return np.zeros(len(X)), np.full(len(X), self.base_sd * math.sqrt(self.factor))

    def with_signal_variance_scaled(self, f):
        self.log.append(f)
        return _FakeModel(self.base_sd, f, self.log)


def test_eiplus_factor_schedule_and_restoration():
    seen = []

    def maximise(model):
        seen.append(model.factor)
        return np.array([0.5])

    # sd(x) = 0.01 sqrt(f) < 0.5 until f = 1e4*... : n = 10 -> factors 10, 100, 1000, 1e4
    base = _FakeModel(0.01)
    x, tries, factors = expected_improvement_plus(maximise, base, n_evaluations=10)
    assert factors == [10.0, 100.0, 1000.0, 10000.0] and tries == 4
    assert seen == [1.0, 10.0, 100.0, 1000.0, 10000.0]
    assert base.factor == 1.0  # the caller's model is untouched
    # never more than 5 tries
    _, tries, factors = expected_improvement_plus(maximise, _FakeModel(1e-6), n_evaluations=10)
    assert tries == 5 and factors == [10.0, 100.0, 1e3, 1e4, 1e5]
    # not over-exploiting: no retry
    _, tries, _ = expected_improvement_plus(maximise, _FakeModel(0.6), n_evaluations=10)
    assert tries == 0


def _clustered_optimiser(ratio):
    """1-d noisy objective sampled densely around its minimum: over-exploitation."""
    opt = ConstrainedBayesOpt([(0.0, 1.0)], {}, n_initial=1, seed=0, exploration_ratio=ratio,
                              n_restarts_gp=0)
    rng = np.random.default_rng(5)
    for x in np.concatenate([np.linspace(0.47, 0.53, 30), [0.02, 0.2, 0.8, 0.98]]):
        opt.tell([x], (x - 0.5) ** 2 + 0.05 * rng.standard_normal(), {})
    return opt


def test_eiplus_triggers_when_over_exploiting():
    plain = _clustered_optimiser(0.0)
    x_plain = plain.ask()
    info0 = plain.last_ask_info
    assert info0["eiplus_tries"] == 0
    # the plain EI maximiser is over-exploiting: std below half the fitted noise std
    assert info0["predicted_objective_std"] < 0.5 * info0["objective_noise_std"]

    opt = _clustered_optimiser(0.5)
    x = opt.ask()
    info = opt.last_ask_info
    assert info["eiplus_tries"] >= 1
    assert info["eiplus_factors"][0] == 34.0  # number of evaluations so far
    assert not np.array_equal(x, x_plain)
    # the returned point is judged with the restored (unmodified) GP: more exploratory
    assert info["predicted_objective_std"] > info0["predicted_objective_std"]
    # restored: the model-based statistics of the plain point are unchanged by EI+
    U, H, obj, cons = opt._fit_models(opt._active_indices())
    _, sd = obj.predict(opt.to_unit(x_plain)[None, :])
    assert sd[0] * obj.y_std == pytest.approx(info0["predicted_objective_std"], rel=1e-12)


# ----------------------------------------------------------------- acquisition numerics
def test_log_ei_is_accurate_and_gradients_match_finite_differences():
    from scipy.integrate import quad
    from scipy.stats import norm

    for z in (-30.0, -8.0, -3.0, 0.0, 2.0):
        ei = quad(lambda t, z=z: (z + t) * norm.pdf(t), -z, np.inf, epsrel=1e-13, epsabs=0)[0]
        assert _log_ei(np.array([z]), np.array([1.0]))[0] == pytest.approx(math.log(ei), rel=1e-9)
    prob = Gardner2014()
    opt = ConstrainedBayesOpt(prob.bounds, prob.thresholds, n_initial=15, seed=3, **FAST)
    for _ in range(15):
        x = opt.ask()
        opt.tell(x, *prob.evaluate(x)[:2])
    U, H, obj, cons = opt._fit_models(opt._active_indices())
    inc = float(obj.predict(U)[0].min())
    rng = np.random.default_rng(1)
    for incumbent in (None, inc):
        for u in rng.uniform(0.05, 0.95, (5, 2)):
            def acq(v, grad=False, incumbent=incumbent):
                return log_acquisition(obj, cons, opt.constraints, incumbent, v[None, :], grad)

            val, g = acq(u, grad=True)
            fd = [(acq(u + e)[0] - acq(u - e)[0]) / 2e-6 for e in np.eye(2) * 1e-6]
            assert np.allclose(g[0], fd, rtol=1e-4, atol=1e-4 * max(1.0, abs(val[0])))


def test_log_ei_gradients_hold_far_into_the_tail_without_overflow():
    """Below z = -1e3 the gradient is the asymptotic ratio, not a difference of huge logs:
    with sd at its floor (z ~ -1e12) the old form overflowed in exp (seen in the
    replication benchmark)."""
    import warnings

    for z in (-2.0, -40.0, -999.0, -1001.0, -5e4, 3.0):
        imp, sd = np.array([z]), np.array([1.0])
        _, d_imp, d_sd = _log_ei(imp, sd, grad=True)
        h = 1e-6 * max(1.0, abs(z))
        fd_imp = (_log_ei(imp + h, sd)[0] - _log_ei(imp - h, sd)[0]) / (2 * h)
        fd_sd = (_log_ei(imp, sd + 1e-6)[0] - _log_ei(imp, sd - 1e-6)[0]) / 2e-6
        assert d_imp[0] == pytest.approx(fd_imp, rel=1e-5)
        assert d_sd[0] == pytest.approx(fd_sd, rel=1e-5)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        val, d_imp, d_sd = _log_ei(np.array([-1.0]), np.array([1e-13]), grad=True)
    assert np.isfinite([val[0], d_imp[0], d_sd[0]]).all()
    assert d_imp[0] == pytest.approx(1e12 / 1e-12, rel=1e-6)  # -z / sd
    assert d_sd[0] == pytest.approx(1e24 / 1e-12, rel=1e-6)   # z^2 / sd


def test_binomial_observation():
    v, var = binomial_observation(98, 100)
    assert v == 0.98 and var == pytest.approx((99 / 102) * (3 / 102) / 100)
    v, var = binomial_observation(100, 100)
    assert v == 1.0 and math.sqrt(var) == pytest.approx(0.0098, abs=1e-4)  # never zero
    with pytest.raises(ValueError):
        binomial_observation(101, 100)


def test_tell_validates_input():
    opt = ConstrainedBayesOpt([(0, 1)], {"p": 0.98}, n_initial=2)
    with pytest.raises(ValueError, match="keys"):
        opt.tell([0.5], 1.0, {"q": 1.0})
    with pytest.raises(ValueError, match="finite"):
        opt.tell([0.5], float("nan"), {"p": 1.0})
    with pytest.raises(ValueError, match="constraint_variances"):
        opt.tell([0.5], 1.0, {"p": 1.0}, {"p": -1.0})
    obs = opt.tell([0.5], 1.0, {"p": 0.97}, {"p": 1e-4}, {"k": np.int64(97)})
    assert not obs.feasible and obs.info == {"k": 97}


# ----------------------------------------------------------------- checkpoint / resume
class _Killed(Exception):
    pass


def _checkpoint_problem():
    prob = NoisyGramacy2016()  # noisy constraint, known variances and a cheap constraint
    opts = dict(n_initial=5, n_iterations=7, seed=11, **FAST)
    return prob, opts


@pytest.mark.parametrize("kill_after", [3, 8])
def test_resume_reproduces_uninterrupted_run_bit_for_bit(tmp_path, kill_after):
    prob, opts = _checkpoint_problem()
    ref = minimize(prob.evaluate, prob.bounds, prob.thresholds,
                   cheap_constraint=prob.cheap_constraint, **opts)
    ref_x = [o.x for o in ref.history]

    ckpt = tmp_path / "run" / "opt.json"
    count = [0]

    def dying(x):
        if count[0] == kill_after:
            raise _Killed()
        count[0] += 1
        return prob.evaluate(x)

    with pytest.raises(_Killed):
        minimize(dying, prob.bounds, prob.thresholds, cheap_constraint=prob.cheap_constraint,
                 checkpoint_path=ckpt, **opts)
    saved = json.loads(ckpt.read_text())
    assert len(saved["optimizer"]["history"]) == kill_after  # only the in-flight one lost

    evaluated = []

    def fun(x):
        evaluated.append(x.copy())
        return prob.evaluate(x)

    res = minimize(fun, prob.bounds, prob.thresholds, cheap_constraint=prob.cheap_constraint,
                   checkpoint_path=ckpt, resume=True, **opts)
    assert len(evaluated) == len(ref_x) - kill_after  # no re-evaluation of the history
    got = [o.x for o in res.history]
    assert len(got) == len(ref_x)
    for a, b in zip(got, ref_x):
        assert a.tobytes() == b.tobytes()
    assert [o.constraints for o in res.history] == [o.constraints for o in ref.history]


def test_state_dict_round_trip_gives_same_next_ask():
    prob, opts = _checkpoint_problem()
    res = minimize(prob.evaluate, prob.bounds, prob.thresholds,
                   cheap_constraint=prob.cheap_constraint, **opts)
    opt = res.optimizer
    state = json.loads(json.dumps(opt.state_dict()))
    twin = ConstrainedBayesOpt.from_state_dict(state, prob.cheap_constraint)
    assert opt.ask().tobytes() == twin.ask().tobytes()


def test_checkpoint_errors(tmp_path):
    prob, opts = _checkpoint_problem()
    ckpt = tmp_path / "opt.json"
    minimize(prob.evaluate, prob.bounds, prob.thresholds, cheap_constraint=prob.cheap_constraint,
             checkpoint_path=ckpt, **{**opts, "n_initial": 3, "n_iterations": 0})
    # existing checkpoint without resume: refused, not overwritten
    with pytest.raises(FileExistsError, match="resume=True"):
        minimize(prob.evaluate, prob.bounds, prob.thresholds,
                 cheap_constraint=prob.cheap_constraint, checkpoint_path=ckpt, **opts)
    # settings differ from the checkpoint's
    with pytest.raises(ValueError, match="seed"):
        minimize(prob.evaluate, prob.bounds, prob.thresholds,
                 cheap_constraint=prob.cheap_constraint, checkpoint_path=ckpt, resume=True,
                 **{**opts, "n_initial": 3, "seed": 12})
    # truncated file: clear error naming the file
    text = ckpt.read_text()
    ckpt.write_text(text[: len(text) // 2])
    with pytest.raises(CheckpointError, match="opt.json.*(corrupt|truncated)"):
        minimize(prob.evaluate, prob.bounds, prob.thresholds,
                 cheap_constraint=prob.cheap_constraint, checkpoint_path=ckpt, resume=True,
                 **{**opts, "n_initial": 3})
    # no temporary files left behind
    assert sorted(p.name for p in tmp_path.iterdir()) == ["opt.json"]


def test_never_asks_for_an_evaluated_design_again():
    """With every constraint observation infeasible (a flat feasibility model) the
    optimiser must still explore: no design is asked twice (with common random numbers a
    repeat would return the same observation)."""
    from optimizer.bayesopt import ConstrainedBayesOpt

    opt = ConstrainedBayesOpt([(0.0, 1.0)] * 3, constraints={"p": 0.98}, n_initial=4,
                              n_iterations=8, seed=3, n_restarts_gp=0)
    seen = []
    for _ in range(12):
        x = opt.ask()
        assert all(np.abs(x - y).max() > 1e-4 for y in seen)
        seen.append(x)
        opt.tell(x, float(x.sum()), {"p": 0.0}, {"p": 0.01})


def test_candidates_draw_uniform_then_local_points_and_keep_away_from_evaluated():
    """optimizer/candidates.py: n uniform points, then n // 4 perturbations of the centres
    at the cycled scales, in that order of draws and inside the cube; a chosen point that
    was evaluated gives way to the best-scoring candidate that was not."""
    from optimizer.candidates import (LOCAL_SCALES, away_from_evaluated, candidate_centres,
                                      candidate_points)

    centres = np.array([[0.5, 0.5], [0.999, 0.001]])
    cand = candidate_points(np.random.default_rng(1), 40, centres)
    rng = np.random.default_rng(1)
    uniform, noise = rng.random((40, 2)), rng.standard_normal((10, 2))
    assert cand.shape == (50, 2) and np.array_equal(cand[:40], uniform)
    scales = np.array([LOCAL_SCALES[k % 3] for k in range(10)])[:, None]
    want = np.clip(centres[np.arange(10) % 2] + scales * noise, 0.0, 1.0)
    assert np.array_equal(cand[40:], want) and cand.min() >= 0.0 and cand.max() <= 1.0

    U = np.array([[0.1, 0.1], [0.2, 0.2], [0.3, 0.3]])
    best = candidate_centres(U, [3.0, 1.0, 2.0], np.array([True, True, False]), {}, {})
    assert np.array_equal(best, U[[1, 0]])          # feasible ones, lowest objective first

    pts = np.array([[0.1, 0.1], [0.7, 0.7], [0.9, 0.2]])
    score_of = lambda P: -P.sum(axis=1)            # noqa: E731
    u, s, moved = away_from_evaluated(pts[0], 9.0, pts, U, score_of)
    assert moved and np.array_equal(u, pts[2]) and s == -1.1
    u, s, moved = away_from_evaluated(pts[1], 9.0, pts, U, score_of)
    assert not moved and np.array_equal(u, pts[1]) and s == 9.0
