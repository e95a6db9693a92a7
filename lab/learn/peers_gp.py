"""Gaussian-process regression of the forward map, scikit-learn fitted, NumPy evaluated.

:func:`fit_gpr` fits scikit-learn's ``GaussianProcessRegressor`` (``ConstantKernel * RBF``
with one length scale per motor, plus ``WhiteKernel``) on inputs scaled to [-1, 1]
(:mod:`lab.learn.peers_base`) and outputs standardised per coordinate, hyperparameters by
maximum marginal likelihood (L-BFGS-B from a white noise of :data:`NOISE_INIT`, plus
``n_restarts`` seeded random starts), one kernel for the three coordinates: right for
noise-free simulation and for noisy measurements alike. The file stores the training
inputs, ``alpha = (K + noise I)^-1 t``, the hyperparameters and the scalings;
:class:`GPRModel` evaluates the posterior mean (m) and its Jacobian (m/rad) in closed form
(:class:`lab.learn.residual.GPCorrection`), and :meth:`GPRModel.predict_with_std` the
posterior standard deviation (m).

**Size limit.** Each likelihood evaluation costs O(N^3) time and O(N^2 n_u) memory, so
:func:`fit_gpr` refuses more than ``max_samples`` (default :data:`GP_MAX_SAMPLES`) with an
InputError unless ``subsample=True`` (a seeded random subset, recorded in the metadata).
The kernel, the Jacobian and the cost measured: docs/design/learn.md.
"""

from __future__ import annotations

import time
import warnings

import numpy as np
from scipy.linalg import cholesky, solve_triangular

from lab.errors import InputError
from lab.learn.model_io import ModelFileError
from lab.learn.peers_base import UNITS, PeerModel, check_data, float_array, input_range, peer_arrays
from lab.learn.residual import GPCorrection

GPR_KIND = "lab.gpr"
GP_MAX_SAMPLES = 2000
#: The white-noise variance the fit starts from (standardised output units), and the bounds
#: of the length scales on inputs scaled to [-1, 1].
NOISE_INIT, LENGTH_SCALE_BOUNDS = 1e-2, (1e-2, 1e2)
# scikit-learn's default GaussianProcessRegressor(alpha=...): added to the kernel
# matrix's diagonal at fit time, so the rebuilt Cholesky factor must add it too
_JITTER = 1e-10
# predict_and_jacobian's (piece, N, n_u) temporaries hold about this many numbers
_CHUNK_ELEMENTS = 2**20


class GPRModel(PeerModel):
    """Posterior of a GP forward model. ``u_train`` (N, n_u) rad, ``alpha`` (N, n_y) (in
    standardised output units), ``length_scales`` (n_u,) and ``signal_variance`` on the
    scaled inputs, ``noise`` (white-noise variance, standardised units), ``y_mean`` and
    ``y_scale`` (n_y,) m. ``estimator`` is the fitted scikit-learn object right after
    :func:`fit_gpr` (None after loading; never saved).

    Parameters
    ----------
    u_min, u_max : array_like
        The input range scaled to [-1, 1], shape (n_u,), rad.
    u_train : array_like
        Training commands, shape (N, n_u), rad.
    alpha : array_like
        ``(K + noise I)^-1 y``, shape (N, n_y), standardised output units.
    length_scales : array_like
        ARD length scales on the scaled inputs, shape (n_u,).
    signal_variance : float
        The RBF kernel's variance, standardised units (> 0).
    noise : float
        White-noise variance, standardised units (>= 0).
    y_mean, y_scale : array_like
        The outputs' standardisation, shape (n_y,), m.
    metadata : dict, optional
        The training record, saved with the file.
    """

    kind = GPR_KIND
    has_jacobian = True

    def __init__(
        self,
        u_min,
        u_max,
        u_train,
        alpha,
        length_scales,
        signal_variance: float,
        noise: float,
        y_mean,
        y_scale,
        metadata=None,
    ):
        super().__init__(u_min, u_max, metadata)
        self.u_train = np.array(u_train, float)
        self.y_mean, self.y_scale = np.array(y_mean, float), np.array(y_scale, float)
        self.noise = float(noise)
        alpha = np.asarray(alpha, float)
        if self.u_train.ndim != 2 or self.u_train.shape[1] != self.n_u:
            raise InputError(f"u_train must be (N, {self.n_u}), got {self.u_train.shape}")
        if alpha.ndim != 2 or self.y_mean.shape != (alpha.shape[1],) or self.y_scale.shape != self.y_mean.shape:
            raise InputError(f"alpha {alpha.shape}, y_mean {self.y_mean.shape}, y_scale {self.y_scale.shape} disagree")
        if self.noise < 0 or signal_variance <= 0 or np.any(self.y_scale <= 0):
            raise InputError("noise must be >= 0, signal variance and y_scale > 0")
        self.posterior = GPCorrection(self.scale(self.u_train), alpha, length_scales, signal_variance, 0.0)
        self._piece = max(1, _CHUNK_ELEMENTS // (len(self.u_train) * self.n_u))
        self._chol = None
        self.estimator = None

    n_y = property(lambda self: self.posterior.alpha.shape[1])
    length_scales = property(lambda self: self.posterior.length_scales)
    signal_variance = property(lambda self: self.posterior.signal_variance)

    def _predict_and_jacobian(self, u2):
        y, J = np.empty((len(u2), self.n_y)), np.empty((len(u2), self.n_y, self.n_u))
        for s in range(0, len(u2), self._piece):
            m, dm = self.posterior.predict_and_jacobian(self.scale(u2[s : s + self._piece]))
            y[s : s + self._piece] = m * self.y_scale + self.y_mean
            J[s : s + self._piece] = dm * self.y_scale[:, None] * self.u_gain
        return y, J

    def _predict(self, u2):
        return self._predict_and_jacobian(u2)[0]

    def _kernel_matrix(self, x1: np.ndarray, x2: np.ndarray) -> np.ndarray:
        d = (x1[:, None, :] - x2[None, :, :]) / self.length_scales
        return self.signal_variance * np.exp(-0.5 * np.sum(d * d, axis=2))

    def predict_with_std(self, u, include_noise: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """Posterior mean and standard deviation, both (N, n_y) m for u (N, n_u) rad, or
        (n_y,) for one u. The variance ``s2 + noise - k*^T (K + noise I)^-1 k*`` is one
        number per u in standardised units, scaled by ``y_scale`` per coordinate.
        ``include_noise`` (default, as scikit-learn's ``return_std``) gives the spread of
        a new *measurement*; False that of the noise-free mean function.

        Parameters
        ----------
        u : array_like
            Commands, shape (N, n_u) or (n_u,), rad.
        include_noise : bool
            Add the white noise to the variance.

        Returns
        -------
        mean, std : numpy.ndarray
            Shape (N, n_y) or (n_y,), m.
        """
        u2, single = self._as_batch(u)
        if self._chol is None:  # O(N^3) once: the factor is not stored in the file
            X = self.posterior.X
            K = self._kernel_matrix(X, X)
            K[np.diag_indices_from(K)] += self.noise + _JITTER
            self._chol = cholesky(K, lower=True)
        mean = np.empty((len(u2), self.n_y))
        std = np.empty_like(mean)
        prior = self.signal_variance + (self.noise if include_noise else 0.0)
        for s in range(0, len(u2), self._piece):
            ks = self._kernel_matrix(self.scale(u2[s : s + self._piece]), self.posterior.X)  # (M, N)
            mean[s : s + self._piece] = (ks @ self.posterior.alpha) * self.y_scale + self.y_mean
            v = solve_triangular(self._chol, ks.T, lower=True)
            var = np.maximum(prior - np.einsum("ij,ij->j", v, v), 0.0)  # round-off can go below 0
            std[s : s + self._piece] = np.sqrt(var)[:, None] * self.y_scale
        return (mean[0], std[0]) if single else (mean, std)

    def _arrays(self) -> dict:
        return {
            "u_train": self.u_train,
            "alpha": self.posterior.alpha,
            "length_scales": self.length_scales,
            "signal_variance": np.array(self.signal_variance),
            "noise": np.array(self.noise),
            "y_mean": self.y_mean,
            "y_scale": self.y_scale,
        }


def fit_gpr(
    u,
    y,
    seed: int = 0,
    *,
    n_restarts: int = 3,
    max_samples: int = GP_MAX_SAMPLES,
    subsample: bool = False,
) -> GPRModel:
    """Fit a GP forward model to commands ``u`` (N, n_u) rad and tips ``y`` (N, n_y) m.

    Kernel ``ConstantKernel * RBF(ARD) + WhiteKernel`` on min-max scaled inputs and
    standardised outputs, hyperparameters by maximum marginal likelihood with
    ``n_restarts`` seeded random restarts. More than ``max_samples`` samples: InputError
    (fitting is O(N^3)), or with ``subsample=True`` a random subset of ``max_samples``
    rows (seeded by ``seed``, recorded in the metadata). ``metadata["training"]`` holds
    the fit time (s), the kernel, the log marginal likelihood and the length scales in rad.

    Parameters
    ----------
    u : array_like
        Commands, shape (N, n_u), rad.
    y : array_like
        Tips, shape (N, n_y), m.
    seed : int
        Seed of the restarts and of the subset.
    n_restarts : int
        Random restarts of the hyperparameter search.
    max_samples : int
        The most samples fitted.
    subsample : bool
        Fit a random subset of ``max_samples`` rows instead of refusing more.

    Returns
    -------
    GPRModel
        The posterior, with its fitted scikit-learn ``estimator``.
    """
    from sklearn.exceptions import ConvergenceWarning
    from sklearn.gaussian_process import GaussianProcessRegressor
    from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

    u, y = check_data(u, y, need=2)
    n_all = len(u)
    if max_samples < 2:
        raise InputError(f"max_samples must be at least 2, got {max_samples}")
    if n_all > max_samples:
        if not subsample:
            raise InputError(
                f"GP regression on {n_all} samples is too large: fitting costs O(N^3) time and O(N^2) memory "
                f"per likelihood evaluation, and this refuses more than max_samples={max_samples}; fit a random "
                f"subset (subsample=True), raise max_samples, or use the MLP for large datasets"
            )
        keep = np.sort(np.random.default_rng(seed).choice(n_all, max_samples, replace=False))
        u, y = u[keep], y[keep]
    t0 = time.perf_counter()
    base = PeerModel(u.min(axis=0), u.max(axis=0))
    x = base.scale(u)
    y_mean, y_scale = y.mean(axis=0), y.std(axis=0)
    y_scale = np.where(y_scale > 0, y_scale, 1.0)
    n_u = u.shape[1]
    # scaled inputs span 2 and standardised outputs have variance 1: bounds wide around that.
    # The noise starts at 1e-2 of the output variance, not near zero: from a tiny noise the
    # likelihood's nearest optimum on noisy measured data is a collapse (length scales at
    # their lower bound, the noise taking everything: 70 mm on the ASL Trunk against 30 mm);
    # from 1e-2 noise-free simulation data still drive it down to their own optimum.
    kernel = ConstantKernel(1.0, (1e-4, 1e4)) * RBF(np.ones(n_u), LENGTH_SCALE_BOUNDS) + WhiteKernel(
        NOISE_INIT, (1e-12, 1.0)
    )
    gp = GaussianProcessRegressor(kernel, alpha=_JITTER, n_restarts_optimizer=n_restarts, random_state=seed)
    with warnings.catch_warnings():
        # noise-free simulation data drive the noise to its lower bound: expected, and
        # the fit is still the likelihood's best within the bounds
        warnings.simplefilter("ignore", ConvergenceWarning)
        gp.fit(x, (y - y_mean) / y_scale)
    wall_s = time.perf_counter() - t0
    k = gp.kernel_
    ls = np.atleast_1d(k.k1.k2.length_scale).astype(float)
    meta = {
        "model": "GaussianProcessRegressor",
        "units": {**UNITS, "length_scales_rad": "rad", "y_mean": "m", "y_scale": "m"},
        "training": {
            "wall_s": wall_s,
            "seed": seed,
            "n_samples": len(u),
            "n_given": n_all,
            "subsampled": n_all > len(u),
            "n_restarts": n_restarts,
            "noise_init_standardised": NOISE_INIT,
            "length_scale_bounds_scaled": list(LENGTH_SCALE_BOUNDS),
            "kernel": str(k),
            "log_marginal_likelihood": float(gp.log_marginal_likelihood_value_),
            "length_scales_scaled": ls.tolist(),
            "length_scales_rad": (ls / base.u_gain).tolist(),
            "signal_variance": float(k.k1.k1.constant_value),
            "noise_variance_standardised": float(k.k2.noise_level),
            "noise_std_m": (np.sqrt(k.k2.noise_level) * y_scale).tolist(),
        },
    }
    model = GPRModel(
        u.min(axis=0),
        u.max(axis=0),
        u,
        gp.alpha_.reshape(len(u), -1),
        ls,
        k.k1.k1.constant_value,
        k.k2.noise_level,
        y_mean,
        y_scale,
        meta,
    )
    model.estimator = gp
    return model


def load_gpr(path) -> GPRModel:
    """Read a file written by :meth:`GPRModel.save`; ModelFileError names the file and problem."""
    arrays, meta, path = peer_arrays(path, GPR_KIND)
    u_min, u_max = input_range(arrays, path)
    n_u = len(u_min)
    u_train = float_array(arrays, "u_train", path, (None, n_u))
    alpha = float_array(arrays, "alpha", path, (len(u_train), None))
    y_mean = float_array(arrays, "y_mean", path, (alpha.shape[1],))
    parts = {
        "length_scales": float_array(arrays, "length_scales", path, (n_u,)),
        "signal_variance": float(float_array(arrays, "signal_variance", path, ())),
        "noise": float(float_array(arrays, "noise", path, ())),
        "y_scale": float_array(arrays, "y_scale", path, y_mean.shape),
    }
    try:
        return GPRModel(u_min, u_max, u_train, alpha, y_mean=y_mean, metadata=meta, **parts)
    except InputError as err:
        raise ModelFileError(f"{path}: {err}") from None
