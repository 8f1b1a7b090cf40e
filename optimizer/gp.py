"""The surrogate: a Gaussian process per modelled quantity (scikit-optimize's regressor).

Kernel ``ConstantKernel * Matern(nu=2.5, one length scale per variable) + WhiteKernel``
(noise level fitted by maximum likelihood; it is excluded from the latent predictions).
Inputs are the unit cube, outputs standardised to zero mean / unit standard deviation
before fitting.  A known observation variance (in the output's own units) is added to the
diagonal of the kernel matrix (the regressor's ``alpha``), on top of the fitted white
noise, which then only absorbs model misfit.  Fits are deterministic given the data and
``random_state``.
"""
from __future__ import annotations

import math
import warnings

import numpy as np
from scipy.linalg import cho_solve, cholesky, solve_triangular
from scipy.spatial.distance import cdist
from skopt.learning import GaussianProcessRegressor
from skopt.learning.gaussian_process.kernels import ConstantKernel, Matern, WhiteKernel

__all__ = ["GPModel"]


class GPModel:
    """A fitted GP on standardised outputs with fast latent predictions.

    ``predict(U)`` returns the latent posterior mean and standard deviation in
    standardised units at unit-cube points ``U`` (shape ``(m, d)``); the white noise is
    excluded. ``noise_sd`` is the fitted white-noise standard deviation (standardised).

    ``shared_var`` (output units squared) and ``shared_mask`` (0/1 per observation): an
    error shared by the masked observations, e.g. the luck of the common random numbers
    they were all estimated on (``o`` in ``y_i = f(x_i) + mask_i o + e_i``, ``o ~ N(0,
    shared_var)``).  The hyperparameters are fitted as without it; the posterior of the
    latent ``f`` then takes it into account, so that many observations on the same samples
    cannot make it surer than those samples allow.
    """

    def __init__(self, U, y, var=None, *, random_state: int, n_restarts: int, kernel=None,
                 shared_var: float = 0.0, shared_mask=None):
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
        self._shared = None
        if shared_var > 0 and shared_mask is not None and np.any(shared_mask):
            self._shared = (float(shared_var) / self.y_std**2,
                            np.asarray(shared_mask, dtype=float))

    def _cache(self):
        gp = self.gp
        k = gp.kernel_  # Sum(Product(Constant, Matern(nu=2.5)), White(0))
        self._c = float(k.k1.k1.constant_value)
        self._ls = np.broadcast_to(np.asarray(k.k1.k2.length_scale, dtype=float),
                                   (gp.X_train_.shape[1],)).copy()
        self._Xs = gp.X_train_ / self._ls
        self._L, self._weights = gp.L_, gp.alpha_
        if self._shared is not None:
            v, m = self._shared
            K = gp.L_ @ gp.L_.T + v * np.outer(m, m)
            self._L = cholesky(K, lower=True, check_finite=False)
            self._weights = cho_solve((self._L, True), gp.y_train_, check_finite=False)

    def predict(self, U, grad: bool = False):
        """Latent posterior mean and std (standardised units) at unit-cube points ``U``
        (``(m, d)``). With ``grad`` also their gradients with respect to ``U``
        (``(m, d)`` each). Matern-5/2 evaluated directly (same hyperparameters as the
        fitted kernel) for speed."""
        if not hasattr(self, "_c"):
            self._cache()
        U = np.atleast_2d(np.asarray(U, dtype=float))
        c = self._c
        if grad:
            D = U[:, None, :] / self._ls - self._Xs[None, :, :]  # (m, n, d) scaled differences
            r = np.sqrt(np.einsum("mnd,mnd->mn", D, D))
        else:
            r = cdist(U / self._ls, self._Xs)
        s5r = math.sqrt(5.0) * r
        e = np.exp(-s5r)
        K = c * (1.0 + s5r + (5.0 / 3.0) * r**2) * e
        mu = K @ self._weights
        v = solve_triangular(self._L, K.T, lower=True, check_finite=False)  # (n, m)
        var = np.maximum(c - np.einsum("nm,nm->m", v, v), 0.0)
        sd = np.sqrt(var)
        if not grad:
            return mu, sd
        # dK/du = -5c/3 (1 + sqrt5 r) exp(-sqrt5 r) (u - x) / l^2
        dK = (-(5.0 / 3.0) * c * (1.0 + s5r) * e)[:, :, None] * (D / self._ls)  # (m, n, d)
        dmu = np.einsum("mnd,n->md", dK, self._weights)
        w = solve_triangular(self._L.T, v, lower=False, check_finite=False)  # K^-1 k, (n, m)
        dvar = -2.0 * np.einsum("nm,mnd->md", w, dK)
        with np.errstate(divide="ignore", invalid="ignore"):
            dsd = np.where(sd[:, None] > 1e-12, dvar / (2.0 * sd[:, None]), 0.0)
        return mu, sd, dmu, dsd

    def with_signal_variance_scaled(self, factor: float) -> GPModel:
        """Copy with the signal (constant-kernel) variance multiplied by ``factor``;
        length scales and noise are kept fixed, data and standardisation unchanged."""
        k = self.gp.kernel_  # Sum(Product(Constant, Matern), White(0))
        const, matern = k.k1.k1, k.k1.k2
        kernel = ConstantKernel(const.constant_value * factor, "fixed") * Matern(
            matern.length_scale, "fixed", nu=matern.nu
        ) + WhiteKernel(max(self.noise_sd**2, 1e-12), "fixed")
        new = GPModel.__new__(GPModel)
        U, y, var = self._fit_args
        last_exc = None
        # the same jitter ladder as the fit: a large factor on a nearly constant kernel
        # (e.g. an exact linear objective) can leave the matrix numerically singular
        for jitter in (0.0, 1e-8, 1e-6, 1e-4):
            gp = GaussianProcessRegressor(
                kernel=kernel, alpha=self._alpha + jitter, optimizer=None, normalize_y=False,
                noise="gaussian", random_state=self._random_state,
            )
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    gp.fit(U, (y - self.y_mean) / self.y_std)
                break
            except (np.linalg.LinAlgError, ValueError) as exc:
                last_exc = exc
        else:
            raise RuntimeError(f"GP refit failed: {last_exc}") from last_exc
        new.gp, new.y_mean, new.y_std = gp, self.y_mean, self.y_std
        new.noise_sd, new._alpha, new._random_state = self.noise_sd, self._alpha, self._random_state
        new._fit_args, new._shared = self._fit_args, self._shared
        return new
