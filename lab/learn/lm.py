"""MATLAB-faithful Levenberg-Marquardt (``trainlm``) for the forward model.

:func:`train_lm` reproduces the ``trainlm`` the paper trained with, with its parameters
(mu = 1e-3, mu_dec = 0.1, mu_inc = 10, mu_max = 1e10, 1000 epochs, max_fail = 6, min_grad =
1e-6: the paper's value, MATLAB's default is 1e-7) and its semantics: MATLAB's stop checks in
its order, the step (J^T J / N_e + mu I) dtheta = -J^T e / N_e (Cholesky; the kernel form when
there are more parameters than residuals), the validation failures, and the best network seen
returned. Errors e = y(u) - y_data are in metres; the performance is MATLAB's ``mse`` over
N_e = N n_y elements; J = dy/dtheta is :meth:`lab.learn.mlp.MLP.parameter_jacobian`, whose
products J^T J and J^T e :mod:`lab.learn.gauss_newton` forms from the layers' structure
(``LMOptions(dense_reference=True)``: J in full, the reference); small systems run on one
BLAS thread (:func:`lab.learn.algorithm_choice.blas_threads`).

Splits (``dividerand``): :mod:`lab.learn.split`; split + init + fit with one seeded random
stream: :func:`lab.learn.train.train`; for large datasets the same loop with a sampled
curvature, :mod:`lab.learn.lm_subsample` (``--algorithm auto`` picks it by size), and Adam and
L-BFGS, :mod:`lab.learn.gradient`; error metrics: :mod:`lab.learn.metrics`.
Each rule, epoch by epoch: docs/design/learn.md.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field

import numpy as np
from scipy.linalg.blas import dsyrk
from scipy.linalg.lapack import dpotrf, dpotrs

from lab.errors import InputError
from lab.learn.algorithm_choice import blas_threads
from lab.learn.gauss_newton import gauss_newton
from lab.learn.metrics import mse_m2
from lab.learn.mlp import MLP
from lab.learn.training_data import TrainingData

#: Why a run stopped, by ``TrainLog.stop_reason``: MATLAB's ``tr.stop`` texts as phrases that
#: sit inside a sentence ("stopped: minimum gradient reached after 26 epochs"), without
#: MATLAB's capital and full stop.
STOP_MESSAGES = {
    "goal": "performance goal met",
    "max_epochs": "maximum epoch reached",
    "min_grad": "minimum gradient reached",
    "mu_max": "maximum mu reached",
    "validation": "validation stop",
}


def stop_message(training: dict) -> str:
    """The stop phrase of a model's ``metadata["training"]``: :data:`STOP_MESSAGES` of its
    ``stop_reason``, else its stored ``stop_message`` (files written before the phrases lost
    MATLAB's full stop keep it; it is dropped here), else ``"?"``.

    Parameters
    ----------
    training : dict
        A model's ``metadata["training"]``.

    Returns
    -------
    str
        The phrase, without a full stop.
    """
    reason = training.get("stop_reason")
    if reason in STOP_MESSAGES:
        return STOP_MESSAGES[reason]
    return str(training.get("stop_message") or reason or "?").rstrip(".")


def mse(model: MLP, u: np.ndarray, y: np.ndarray) -> float:
    """MATLAB ``mse`` of ``model`` on (u, y): mean over samples and coordinates of the squared
    error (units of y squared); NaN for an empty set.

    Parameters
    ----------
    model : MLP
        The network.
    u : numpy.ndarray
        Inputs, shape (N, n_u), rad.
    y : numpy.ndarray
        Targets, shape (N, n_y), m.

    Returns
    -------
    float
        The mean squared error, m^2.
    """
    return mse_m2(model.predict(u), y) if len(u) else float("nan")


@dataclass(frozen=True)
class LMOptions:
    """``trainlm``'s parameters, MATLAB's defaults but ``min_grad`` (the paper's).

    Parameters
    ----------
    epochs : int
        Maximum number of epochs.
    mu, mu_dec, mu_inc, mu_max : float
        Initial damping, its factor after an accepted step, after a rejected one, and the
        damping that stops training (dimensionless, normalised performance per unit step).
    max_fail : int
        Consecutive epochs of worse validation error that stop training.
    min_grad : float
        Gradient norm ``2 |J^T e| / N_e`` at or below which training stops (m^2 per unit weight).
    goal : float
        Training MSE at or below which training stops (m^2).
    max_jacobian_mb : float
        Memory bound for J, MB: J is built in chunks of samples (MATLAB's ``mem_reduc``).
    dense_reference : bool
        The reference linear algebra: J formed in full by
        :meth:`lab.learn.mlp.MLP.parameter_jacobian` and J^T J by BLAS ``syrk`` (and, for
        Bayesian regularisation, gamma from the eigenvalues of J^T J). False (the default):
        :func:`lab.learn.gauss_newton.gauss_newton`'s products from the layers' structure
        (and gamma from a Cholesky factor): the same algorithm, equal to round-off, faster.
    """

    epochs: int = 1000
    mu: float = 1e-3
    mu_dec: float = 0.1
    mu_inc: float = 10.0
    mu_max: float = 1e10
    max_fail: int = 6
    min_grad: float = 1e-6
    goal: float = 0.0
    max_jacobian_mb: float = 256.0
    dense_reference: bool = False

    def __post_init__(self):
        if not isinstance(self.dense_reference, bool):
            name = f"{type(self).__name__}.dense_reference"
            raise InputError(f"{name} must be True or False, got {self.dense_reference!r}")


@dataclass
class TrainLog:
    """What a training run did: per-epoch record (MATLAB's ``tr``), why it stopped, best epoch.

    Attributes
    ----------
    algorithm : str
        The trainer, e.g. ``"lm"``, ``"br"``, ``"adam"``, ``"lbfgs"``.
    stop_reason : str
        Why it stopped, a key of :data:`STOP_MESSAGES`.
    epochs, best_epoch : int
        Epochs run and the epoch whose weights were kept.
    history : dict
        Per-epoch arrays (MSE per set in m^2, mu, gradient norm, ...).
    options : dict
        The options it ran with.
    wall_s : float
        Wall time, s.
    """

    algorithm: str
    stop_reason: str
    epochs: int
    best_epoch: int
    history: dict = field(default_factory=dict)
    options: dict = field(default_factory=dict)
    wall_s: float = 0.0


def _checked(options, cls):
    """``options``, or ``cls()`` for None; InputError for another type."""
    if options is None:
        return cls()
    if type(options) is not cls:
        raise InputError(f"options must be of type {cls.__name__}, got {type(options).__name__}")
    return options


def _arrays(data: TrainingData) -> tuple[np.ndarray, ...]:
    """The six arrays of ``data``: (u, y) of the training, validation and test sets."""
    if not isinstance(data, TrainingData):
        raise InputError(f"data must be a TrainingData, got {type(data).__name__}")
    return data.u_train, data.y_train, data.u_val, data.y_val, data.u_test, data.y_test


def _jacobian_products(model, u, y, max_mb, dense=False, work=None):
    """Training MSE, J^T e / N_e, and the LM system: ("primal", J^T J / N_e) or, when there
    are more parameters than residuals, ("kernel", J J^T, J, e). Only upper triangles are
    filled (BLAS syrk on the F-ordered view J^T, no copies). The primal form comes from
    :func:`lab.learn.gauss_newton.gauss_newton` (its arrays kept in ``work`` across epochs)
    unless ``dense`` (the reference: J in full)."""
    n_e, n_p = y.size, model.n_params
    if n_p > n_e and 8 * n_e * n_p <= max_mb * 2**20:
        y_hat, J = model.parameter_jacobian(u)
        e = (y_hat - y).ravel()
        return float(e @ e / n_e), J.T @ e / n_e, ("kernel", dsyrk(1.0, J.T, trans=1), J, e)
    if not dense:
        sse, JE, JJ = gauss_newton(model, u, y, max_mb, work=work)
        JJ /= n_e
        return sse / n_e, JE / n_e, ("primal", JJ)
    chunk = max(1, int(max_mb * 2**20 // (8 * y.shape[1] * n_p)))
    JJ, JE, sse = None, np.zeros(n_p), 0.0
    for s in range(0, len(u), chunk):
        y_hat, J = model.parameter_jacobian(u[s : s + chunk])
        e = (y_hat - y[s : s + chunk]).ravel()
        JJ = dsyrk(1.0 / n_e, J.T) if JJ is None else dsyrk(1.0 / n_e, J.T, beta=1.0, c=JJ, overwrite_c=1)
        JE += J.T @ e
        sse += float(e @ e)
    return sse / n_e, JE / n_e, ("primal", JJ)


def _lm_step(system, JE, mu, n_e, buf):
    """dtheta of one LM trial with damping mu; None if the damped matrix is not numerically
    positive definite (Cholesky fails). ``buf`` is scratch space of the system's size."""
    buf[...] = system[1]
    if system[0] == "primal":  # (J^T J / N_e + mu I) dtheta = -J^T e / N_e
        buf.flat[:: len(buf) + 1] += mu
        rhs = -JE
    else:  # dtheta = -J^T (J J^T + mu N_e I)^{-1} e
        buf.flat[:: len(buf) + 1] += mu * n_e
        rhs = system[3]
    U, info = dpotrf(buf, lower=0, overwrite_a=1)  # LAPACK directly: the wrappers' checks cost as much
    if info != 0:
        return None
    c, info = dpotrs(U, rhs, lower=0)
    if info != 0 or not np.all(np.isfinite(c)):
        return None
    return c if system[0] == "primal" else -(system[2].T @ c)


def lm_step(model: MLP, u: np.ndarray, y: np.ndarray, mu: float, max_jacobian_mb: float = 256.0):
    """One Levenberg-Marquardt trial step as :func:`train_lm` takes it: ``dtheta``
    (n_params,) solving ``(J^T J / N_e + mu I) dtheta = -J^T e / N_e`` at ``model``'s
    parameters, for inputs ``u`` (N, n_u) rad and targets ``y`` (N, n_y) m; None if the
    damped matrix is not numerically positive definite.

    Parameters
    ----------
    model : MLP
        The network at its current parameters.
    u : numpy.ndarray
        Inputs, shape (N, n_u), rad.
    y : numpy.ndarray
        Targets, shape (N, n_y), m.
    mu : float
        The damping.
    max_jacobian_mb : float
        Memory bound for J, MB.

    Returns
    -------
    numpy.ndarray or None
        dtheta, shape (n_params,).
    """
    y = np.asarray(y, float)
    _, JE, system = _jacobian_products(model, np.asarray(u, float), y, max_jacobian_mb)
    return _lm_step(system, JE, float(mu), y.size, np.empty_like(system[1]))


def train_lm(model: MLP, data: TrainingData, options: LMOptions | None = None, progress=None) -> tuple[MLP, TrainLog]:
    """Levenberg-Marquardt with ``trainlm`` semantics.

    Parameters
    ----------
    model : MLP
        The initial network (not changed; a copy is trained).
    data : TrainingData
        Training set (N, n_u) -> (N, n_y) in the model's units (rad -> m); the validation
        set stops training after ``max_fail`` worse epochs, the test set is only recorded.
    options : LMOptions, optional
        Default ``LMOptions()``.
    progress : callable, optional
        ``progress(epoch, history_row)``, called once per epoch.

    Returns
    -------
    MLP
        The best network seen (lowest validation MSE, or training MSE without validation).
    TrainLog
        Per epoch ``epoch``, ``perf``, ``vperf``, ``tperf`` (MSE, m^2), ``mu``, ``gradient``
        and ``val_fail``; the stop reason and the best epoch.
    """
    opt = _checked(options, LMOptions)
    _arrays(data)
    with blas_threads(data.y_train.size, model.n_params):
        return _train_lm(model, data, opt, progress)


def _train_lm(model, data, opt, progress, products=None, algorithm="lm"):
    """trainlm's loop; ``products(net)`` -> (MSE, J^T e / N_e, system) of the training set
    (default :func:`_jacobian_products`; :mod:`lab.learn.lm_subsample` passes its own)."""
    t0 = time.perf_counter()
    net = model.copy()
    u_train, y_train, u_val, y_val, u_test, y_test = _arrays(data)
    has_val, n_e = data.has_validation, y_train.size
    theta = net.get_params()
    if products is None:
        work, mb, dense = {}, opt.max_jacobian_mb, opt.dense_reference
        products = lambda net: _jacobian_products(net, u_train, y_train, mb, dense, work)  # noqa: E731
    perf, JE, system = products(net)
    buf = np.empty_like(system[1], order="F")
    vperf = mse(net, u_val, y_val)
    best = {"theta": theta.copy(), "perf": perf, "vperf": vperf, "epoch": 0}
    mu, val_fail, hist, stop = opt.mu, 0, [], None
    for epoch in range(opt.epochs + 1):
        gradient = 2.0 * float(np.linalg.norm(JE))
        if perf <= opt.goal:
            stop = "goal"
        elif epoch == opt.epochs:
            stop = "max_epochs"
        elif gradient <= opt.min_grad:
            stop = "min_grad"
        elif mu >= opt.mu_max:
            stop = "mu_max"
        elif val_fail >= opt.max_fail:
            stop = "validation"
        hist.append((epoch, perf, vperf, mse(net, u_test, y_test), mu, gradient, val_fail))
        if progress is not None:
            progress(epoch, hist[-1])
        if stop:
            break
        while mu <= opt.mu_max:
            step = _lm_step(system, JE, mu, n_e, buf)
            if step is not None:
                net.set_params(theta + step)
                if mse(net, u_train, y_train) < perf:
                    theta = theta + step
                    mu = max(mu * opt.mu_dec, 1e-20)
                    break
            mu *= opt.mu_inc
        net.set_params(theta)
        perf, JE, system = products(net)
        vperf = mse(net, u_val, y_val)
        improved = vperf < best["vperf"] if has_val else perf < best["perf"]
        if improved:
            best = {"theta": theta.copy(), "perf": perf, "vperf": vperf, "epoch": epoch + 1}
            val_fail = 0
        elif has_val and vperf > best["vperf"]:
            val_fail += 1
    net.set_params(best["theta"])
    cols = ("epoch", "perf", "vperf", "tperf", "mu", "gradient", "val_fail")
    history = {c: np.array([row[i] for row in hist]) for i, c in enumerate(cols)}
    log = TrainLog(algorithm, stop, int(hist[-1][0]), best["epoch"], history, asdict(opt), time.perf_counter() - t0)
    return net, log
