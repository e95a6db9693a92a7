"""The residual transfer model: the simulation network plus a Gaussian-process correction.

A network trained on simulated data is wrong on the real arm by a smooth, command-
dependent bias ``r(u) = y_real(u) - y_sim(u)`` (m; the as-built defects: softer foam,
shifted eyelets, slack). With a few real samples, :func:`fit_residual` learns ``r`` by
Gaussian-process regression (scikit-learn: a constant times an anisotropic RBF kernel plus
white noise, maximum marginal likelihood), and :class:`ResidualModel` is
``y(u) = y_sim(u) + m(u)``, ``m`` the posterior mean, whose Jacobian (m/rad) is closed-form
and added to the network's, so inverse kinematics still gets an exact Jacobian. Far from
the real samples ``m`` falls back to a constant (the mean residual).

One ``.npz`` holds both parts (no pickle): the network's arrays under ``base.``, the process
under ``gp.``, and a ``metadata`` JSON with ``kind: "lab.residual"``; :func:`lab.learn.mlp.load_model`
reads either kind, so ``track --model`` takes it. The formulas: docs/design/learn.md.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from lab.errors import InputError
from lab.files import atomic_open, json_default
from lab.learn.model_io import FORMAT_VERSION, ModelFileError, _need, _read_arrays, file_metadata, model_arrays

__all__ = ["RESIDUAL_KIND", "GPCorrection", "ResidualModel", "fit_residual", "load_residual"]

RESIDUAL_KIND = "lab.residual"


class GPCorrection:
    """Posterior mean of a GP with kernel ``s2 * RBF(length_scales)``: inputs ``X`` (N, n_u)
    rad, weights ``alpha`` (N, n_y), constant ``offset`` (n_y,) m.

    Parameters
    ----------
    X : array_like
        Inputs of the real samples, shape (N, n_u), rad.
    alpha : array_like
        Posterior weights, shape (N, n_y), m.
    length_scales : array_like
        RBF length scales, shape (n_u,), rad.
    signal_variance : float
        s2, the kernel's variance (dimensionless factor of ``alpha``).
    offset : array_like
        The constant the mean falls back to far from the data, shape (n_y,), m.
    """

    def __init__(self, X, alpha, length_scales, signal_variance: float, offset):
        self.X, self.alpha = np.asarray(X, float), np.asarray(alpha, float)
        self.length_scales = np.asarray(length_scales, float).reshape(-1)
        self.signal_variance, self.offset = float(signal_variance), np.asarray(offset, float)
        if self.X.ndim != 2 or self.alpha.shape[0] != len(self.X) or self.length_scales.shape != (self.X.shape[1],):
            raise InputError("GP correction: X (N, n_u), alpha (N, n_y) and length_scales (n_u,) do not match")

    def _k(self, u2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        d = (u2[:, None, :] - self.X[None, :, :]) / self.length_scales  # (M, N, n_u), scaled
        return self.signal_variance * np.exp(-0.5 * np.sum(d * d, axis=2)), d

    def predict_and_jacobian(self, u2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The posterior mean and its Jacobian.

        Parameters
        ----------
        u2 : numpy.ndarray
            Commands, shape (M, n_u), rad.

        Returns
        -------
        m : numpy.ndarray
            Shape (M, n_y), m.
        dm : numpy.ndarray
            dm/du, shape (M, n_y, n_u), m/rad.
        """
        k, d = self._k(u2)
        m = k @ self.alpha + self.offset
        dk = -k[:, :, None] * d / self.length_scales  # dk/du (M, N, n_u)
        return m, np.einsum("mnj,nk->mkj", dk, self.alpha)


class ResidualModel:
    """``base`` (an :class:`lab.learn.mlp.MLP` trained on simulation) plus ``correction``
    (:class:`GPCorrection`); the forward-map interface of the network (``predict``,
    ``predict_and_jacobian``, ``jacobian``, ``n_u``, ``n_y``, ``save``).

    Parameters
    ----------
    base : MLP
        The network trained on simulation.
    correction : GPCorrection
        The residual's posterior mean.
    metadata : dict, optional
        The fit's record, saved with the file.
    """

    def __init__(self, base, correction: GPCorrection, metadata: dict | None = None):
        self.base, self.correction = base, correction
        self.metadata = dict(metadata or {})
        if correction.X.shape[1] != base.n_u or correction.alpha.shape[1] != base.n_y:
            raise InputError(f"GP correction maps {correction.X.shape[1]} inputs, the network {base.n_u}")

    n_u = property(lambda self: self.base.n_u)
    n_y = property(lambda self: self.base.n_y)
    layer_sizes = property(lambda self: self.base.layer_sizes)

    def __repr__(self) -> str:
        return f"ResidualModel({self.base!r} + GP on {len(self.correction.X)} real samples)"

    def predict_and_jacobian(self, u):
        """y (N, n_y) m and dy/du (N, n_y, n_u) m/rad; a single u (n_u,) gives (n_y,), (n_y, n_u).

        Parameters
        ----------
        u : array_like
            Commands, shape (N, n_u) or (n_u,), rad.

        Returns
        -------
        y : numpy.ndarray
            Shape (N, n_y) or (n_y,), m.
        J : numpy.ndarray
            dy/du, shape (N, n_y, n_u) or (n_y, n_u), m/rad.
        """
        u = np.asarray(u, float)
        single = u.ndim == 1
        y, J = self.base.predict_and_jacobian(u[None] if single else u)
        m, dm = self.correction.predict_and_jacobian(u[None] if single else u)
        y, J = y + m, J + dm
        return (y[0], J[0]) if single else (y, J)

    def predict(self, u) -> np.ndarray:
        """The network plus the correction.

        Parameters
        ----------
        u : array_like
            Commands, shape (N, n_u) or (n_u,), rad.

        Returns
        -------
        numpy.ndarray
            y, shape (N, n_y) or (n_y,), m.
        """
        return self.predict_and_jacobian(u)[0]

    def jacobian(self, u) -> np.ndarray:
        """The Jacobian of :meth:`predict`.

        Parameters
        ----------
        u : array_like
            Commands, shape (N, n_u) or (n_u,), rad.

        Returns
        -------
        numpy.ndarray
            dy/du, shape (N, n_y, n_u) or (n_y, n_u), m/rad.
        """
        return self.predict_and_jacobian(u)[1]

    def save(self, path) -> Path:
        """Write both parts to one ``.npz`` atomically (no pickle).

        Parameters
        ----------
        path : str or Path
            The model file.

        Returns
        -------
        Path
            ``path``.
        """
        path = Path(path)
        meta = {"format_version": FORMAT_VERSION, "kind": RESIDUAL_KIND, **self.metadata}
        arrays = {f"base.{k}": v for k, v in model_arrays(self.base).items()}
        c = self.correction
        arrays.update(
            {
                "metadata": np.array(json.dumps(meta, default=json_default, allow_nan=False)),
                "gp.X": c.X,
                "gp.alpha": c.alpha,
                "gp.length_scales": c.length_scales,
                "gp.signal_variance": np.array(c.signal_variance),
                "gp.offset": c.offset,
            }
        )
        with atomic_open(path, "wb") as fh:
            np.savez(fh, **arrays)
        return path


def fit_residual(base, u_real, y_real, seed: int = 0) -> ResidualModel:
    """Fit the GP correction to ``y_real - base(u_real)``: ``u_real`` (N, n_u) rad,
    ``y_real`` (N, n_y) m, N >= 1. Hyperparameters by maximum marginal likelihood
    (scikit-learn, a few seeded restarts); the white-noise level absorbs motion-capture
    noise and hysteresis, which no function of u can fit.

    Parameters
    ----------
    base : MLP
        The network trained on simulation.
    u_real : array_like
        Real commands, shape (N, n_u), rad.
    y_real : array_like
        Real tips, shape (N, n_y), m.
    seed : int
        Seed of the restarts.

    Returns
    -------
    ResidualModel
        ``base`` plus the fitted correction.
    """
    import warnings

    from sklearn.exceptions import ConvergenceWarning
    from sklearn.gaussian_process import GaussianProcessRegressor
    from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

    u, y = np.asarray(u_real, float), np.asarray(y_real, float)
    if u.ndim != 2 or y.shape != (len(u), base.n_y) or u.shape[1] != base.n_u or len(u) < 1:
        raise InputError(f"expected u_real (N, {base.n_u}) and y_real (N, {base.n_y}), got {u.shape} and {y.shape}")
    r = y - base.predict(u)
    offset = r.mean(axis=0)
    span = np.ptp(u, axis=0)
    span = np.where(span > 0, span, 1.0)
    kernel = ConstantKernel(max(float(np.var(r - offset)), 1e-8), (1e-10, 1.0)) * RBF(
        span, np.column_stack([1e-2 * span, 1e2 * span])
    ) + WhiteKernel(1e-7, (1e-10, 1e-3))
    gp = GaussianProcessRegressor(kernel, n_restarts_optimizer=3, random_state=seed, normalize_y=False)
    with warnings.catch_warnings():
        # with a handful of samples the optimum often sits on a bound (no noise seen, a
        # flat direction): expected, and the fit is still the best the data allow
        warnings.simplefilter("ignore", ConvergenceWarning)
        gp.fit(u, r - offset)
    k = gp.kernel_
    correction = GPCorrection(u, gp.alpha_.reshape(len(u), -1), k.k1.k2.length_scale, k.k1.k1.constant_value, offset)
    meta = {
        "method": "residual",
        "kernel": str(k),
        "n_real": len(u),
        "white_noise_m2": float(k.k2.noise_level),
        "units": {"u": "rad", "y": "m"},
    }
    return ResidualModel(base, correction, meta)


def load_residual(path, network, activations) -> ResidualModel:
    """Read a file written by :meth:`ResidualModel.save`; ``network(**kwargs)`` builds the
    simulation network from :func:`lab.learn.model_io.read_model`'s keyword arguments
    (:func:`lab.learn.mlp.load_model` passes ``MLP``; this module never imports it).
    Raises :class:`ModelFileError` naming the file and the problem.

    Parameters
    ----------
    path : str or Path
        The model file.
    network : callable
        Builds the simulation network from :func:`lab.learn.model_io.read_model`'s keyword arguments.
    activations : tuple of str
        The activation names ``network`` can build.

    Returns
    -------
    ResidualModel
        The network and the correction as saved.
    """
    from lab.learn.model_io import read_model

    path = Path(path)
    arrays = _read_arrays(path)
    meta = file_metadata(path, arrays)
    if meta.get("kind") != RESIDUAL_KIND:
        raise ModelFileError(f"{path}: kind {meta.get('kind')!r} is not {RESIDUAL_KIND!r}")
    base = network(**read_model(path, activations, prefix="base."))
    parts = {k: _need(arrays, f"gp.{k}", path) for k in ("X", "alpha", "length_scales", "signal_variance", "offset")}
    for key, arr in parts.items():
        if arr.dtype.kind != "f" or not np.all(np.isfinite(arr)):
            raise ModelFileError(f"{path}: array 'gp.{key}' is not finite floating point")
    try:
        correction = GPCorrection(**{k: (v[()] if k == "signal_variance" else v) for k, v in parts.items()})
        return ResidualModel(base, correction, {k: v for k, v in meta.items() if k not in ("format_version", "kind")})
    except InputError as err:
        raise ModelFileError(f"{path}: {err}") from None
