"""scikit-learn's ``MLPRegressor`` as a forward model, with its Jacobian in closed form.

:func:`fit_sklearn_mlp` fits ``MLPRegressor`` (tanh hidden layers, linear output,
L-BFGS on the squared error plus scikit-learn's small L2 penalty ``alpha``) on inputs
scaled to [-1, 1] (the network's ``mapminmax``, :mod:`lab.learn.peers_base`) and outputs
standardised per coordinate, ``t = (y - y_mean) / y_scale``. With the fitted
``coefs_[l]`` (n_l, n_{l+1}) and ``intercepts_[l]``,

    a_0 = x(u),   a_l = tanh(a_{l-1} W_l + b_l),   y = y_mean + y_scale (a_{L-1} W_L + b_L),
    dy/du = diag(y_scale) W_L^T D_{L-1} W_{L-1}^T ... D_1 W_1^T diag(g_u),  D_l = diag(1 - a_l^2).

That is exactly :class:`lab.learn.MLP` with weights ``W_l^T`` and output range
``y_mean -/+ y_scale``, so :class:`SklearnMLPModel` evaluates both through one (the
Appendix's chain rule, tested there) and stores the scikit-learn arrays themselves
(``coefs_l``, ``intercepts_l``; no pickle). The file has ``kind: "lab.sklearn_mlp"``.
"""

from __future__ import annotations

import time
import warnings

import numpy as np

from lab.errors import InputError
from lab.learn.mlp import MLP
from lab.learn.model_io import ModelFileError
from lab.learn.peers_base import UNITS, PeerModel, check_data, float_array, input_range, peer_arrays

SKLEARN_MLP_KIND = "lab.sklearn_mlp"


class SklearnMLPModel(PeerModel):
    """A fitted ``MLPRegressor``: ``coefs`` [(n_l, n_{l+1})], ``intercepts`` [(n_{l+1},)] on
    scaled inputs (``u_min, u_max`` (n_u,) rad) and standardised outputs (``y_mean,
    y_scale`` (n_y,) m). ``estimator`` is the scikit-learn object right after fitting
    (None after loading; never saved).

    Parameters
    ----------
    u_min, u_max : array_like
        The input range scaled to [-1, 1], shape (n_u,), rad.
    coefs : sequence of array_like
        ``coefs[l]`` of shape (n_l, n_{l+1}).
    intercepts : sequence of array_like
        ``intercepts[l]`` of shape (n_{l+1},).
    y_mean, y_scale : array_like
        The outputs' standardisation, shape (n_y,), m.
    metadata : dict, optional
        The training record, saved with the file.
    """

    kind = SKLEARN_MLP_KIND
    has_jacobian = True

    def __init__(self, u_min, u_max, coefs, intercepts, y_mean, y_scale, metadata=None):
        super().__init__(u_min, u_max, metadata)
        self.coefs = [np.array(c, float) for c in coefs]
        self.intercepts = [np.array(b, float) for b in intercepts]
        self.y_mean, self.y_scale = np.array(y_mean, float), np.array(y_scale, float)
        if not self.coefs or self.coefs[0].ndim != 2 or self.coefs[0].shape[0] != self.n_u:
            raise InputError(f"the first layer must take {self.n_u} inputs")
        if np.any(self.y_scale <= 0) or self.y_scale.shape != self.y_mean.shape:
            raise InputError("y_scale must be positive, of the shape of y_mean")
        # the same network in lab's form: W_l^T, and mapminmax^-1 over [y_mean - y_scale, y_mean + y_scale]
        self.net = MLP(
            [c.T for c in self.coefs],
            self.intercepts,
            self.u_min,
            self.u_max,
            self.y_mean - self.y_scale,
            self.y_mean + self.y_scale,
            "tanh",
        )
        if self.net.n_y != len(self.y_mean):
            raise InputError(f"the last layer gives {self.net.n_y} outputs but y_mean has {len(self.y_mean)}")

    n_y = property(lambda self: self.net.n_y)
    hidden = property(lambda self: self.net.hidden)

    def _predict(self, u2):
        return self.net.predict(u2)

    def _predict_and_jacobian(self, u2):
        return self.net.predict_and_jacobian(u2)

    def _arrays(self) -> dict:
        out = {"y_mean": self.y_mean, "y_scale": self.y_scale}
        for l, (c, b) in enumerate(zip(self.coefs, self.intercepts)):
            out[f"coefs_{l}"], out[f"intercepts_{l}"] = c, b
        return out


def fit_sklearn_mlp(
    u, y, hidden=(20, 20), seed: int = 0, *, alpha: float = 1e-4, max_iter: int = 5000, tol: float = 1e-9
) -> SklearnMLPModel:
    """Fit ``MLPRegressor(hidden, tanh, lbfgs)`` to commands ``u`` (N, n_u) rad and tips
    ``y`` (N, n_y) m; ``alpha`` is scikit-learn's L2 penalty, ``max_iter`` the L-BFGS
    iteration limit, ``tol`` its gradient tolerance (tight: the default 1e-4 stops
    millimetres short on standardised outputs). ``metadata["training"]`` records the fit
    time (s), iterations, final loss and whether L-BFGS converged before ``max_iter``.

    Parameters
    ----------
    u : array_like
        Commands, shape (N, n_u), rad.
    y : array_like
        Tips, shape (N, n_y), m.
    hidden : tuple of int
        Hidden layer widths.
    seed : int
        Seed of the initial weights.
    alpha : float
        L2 penalty.
    max_iter : int
        L-BFGS iteration limit.
    tol : float
        Gradient tolerance.

    Returns
    -------
    SklearnMLPModel
        The fitted network, with its scikit-learn ``estimator``.
    """
    from sklearn.exceptions import ConvergenceWarning
    from sklearn.neural_network import MLPRegressor

    u, y = check_data(u, y, need=2)
    hidden = tuple(int(h) for h in hidden)
    if not hidden or any(h < 1 for h in hidden):
        raise InputError(f"hidden layer widths must be positive (at least one layer), got {hidden}")
    t0 = time.perf_counter()
    base = PeerModel(u.min(axis=0), u.max(axis=0))
    y_mean, y_scale = y.mean(axis=0), y.std(axis=0)
    y_scale = np.where(y_scale > 0, y_scale, 1.0)
    est = MLPRegressor(
        hidden_layer_sizes=hidden,
        activation="tanh",
        solver="lbfgs",
        alpha=alpha,
        max_iter=max_iter,
        tol=tol,
        random_state=seed,
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ConvergenceWarning)
        est.fit(base.scale(u), (y - y_mean) / y_scale)
    wall_s = time.perf_counter() - t0
    converged = not any(issubclass(w.category, ConvergenceWarning) for w in caught)
    meta = {
        "model": "MLPRegressor",
        "units": {**UNITS, "y_mean": "m", "y_scale": "m"},
        "architecture": {"layer_sizes": [u.shape[1], *hidden, y.shape[1]], "activation": "tanh"},
        "training": {
            "wall_s": wall_s,
            "seed": seed,
            "n_samples": len(u),
            "solver": "lbfgs",
            "alpha": alpha,
            "max_iter": max_iter,
            "tol": tol,
            "n_iter": int(est.n_iter_),
            "loss": float(est.loss_),
            "converged": converged,
        },
    }
    model = SklearnMLPModel(u.min(axis=0), u.max(axis=0), est.coefs_, est.intercepts_, y_mean, y_scale, meta)
    model.estimator = est
    return model


def load_sklearn_mlp(path) -> SklearnMLPModel:
    """Read a file written by :meth:`SklearnMLPModel.save`; ModelFileError names the file and problem."""
    arrays, meta, path = peer_arrays(path, SKLEARN_MLP_KIND)
    u_min, u_max = input_range(arrays, path)
    n_layers = sum(1 for k in arrays if k.startswith("coefs_"))
    if n_layers < 1:
        raise ModelFileError(f"{path}: missing array 'coefs_0' (truncated or not a lab model file)")
    coefs, intercepts, n_in = [], [], len(u_min)
    for l in range(n_layers):
        coefs.append(float_array(arrays, f"coefs_{l}", path, (n_in, None)))
        n_in = coefs[-1].shape[1]
        intercepts.append(float_array(arrays, f"intercepts_{l}", path, (n_in,)))
    y_mean = float_array(arrays, "y_mean", path, (n_in,))
    try:
        return SklearnMLPModel(
            u_min, u_max, coefs, intercepts, y_mean, float_array(arrays, "y_scale", path, (n_in,)), meta
        )
    except InputError as err:
        raise ModelFileError(f"{path}: {err}") from None
