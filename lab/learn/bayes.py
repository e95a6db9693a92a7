"""Bayesian regularisation (MATLAB ``trainbr``, MacKay 1992) for the forward model.

:func:`train_br` minimises F(theta) = beta E_D + alpha E_W, with E_D = sum_i |y(u_i) - y_i|^2
(m^2) and E_W = |theta|^2 (every weight and bias, normalised space), and re-estimates alpha
and beta after every accepted step from the evidence (MacKay's fixed point):
gamma = sum_k lambda_k / (lambda_k + alpha / beta) (lambda_k: eigenvalues of J^T J; gamma: the
effective number of parameters), alpha = gamma / (2 E_W), beta = (N_e - gamma) / (2 E_D), with
N_e = N n_y residuals; 1 / sqrt(2 beta) estimates the noise per coordinate (m). Steps use
``trainlm``'s damping schedule and :mod:`lab.learn.lm`'s linear algebra, not copies. Defaults
are ``trainbr``'s: ``mu = 0.005``, ``min_grad = 1e-7``, 1000 epochs; the validation set never
stops training, and the last network is returned.

The step in lm's units and the deliberate differences from MATLAB: docs/design/learn.md.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass

import numpy as np
from scipy.linalg import eigvalsh
from scipy.linalg.lapack import dpotrf, dtrtri

from lab.learn.algorithm_choice import blas_threads
from lab.learn.lm import LMOptions, TrainLog, _arrays, _checked, _jacobian_products, _lm_step, mse
from lab.learn.mlp import MLP
from lab.learn.training_data import TrainingData

__all__ = ["BROptions", "effective_parameters", "train_br", "br_summary"]


@dataclass(frozen=True)
class BROptions(LMOptions):
    """``trainbr``'s parameters: :class:`lab.learn.lm.LMOptions`' fields with ``trainbr``'s
    defaults, ``mu = 0.005`` and ``min_grad = 1e-7`` (1000 epochs); ``max_fail`` is ignored
    (the validation set never stops Bayesian regularisation).

    Parameters
    ----------
    epochs, mu, mu_dec, mu_inc, mu_max, max_fail, min_grad, goal, max_jacobian_mb, dense_reference
        As :class:`lab.learn.lm.LMOptions`; ``min_grad`` bounds the gradient of the
        regularised objective.
    """

    mu: float = 0.005
    min_grad: float = 1e-7


def effective_parameters(system, ratio: float, dense: bool = False) -> float:
    """MacKay's gamma = sum_k lambda_k / (lambda_k + ratio) over the eigenvalues of J^T J,
    from a system of :func:`lab.learn.lm._jacobian_products` (upper triangle of J^T J / N_e
    or of J J^T); ``ratio`` = alpha / beta (m^2 per unit squared weight). Computed as
    m - r tr((S + r I)^-1) (S the stored m x m matrix, r the ratio in its scale) from a
    Cholesky factor and its inverse; ``dense`` (the reference), or a factor that fails,
    from the eigenvalues (negative round-off ones clipped to 0)."""
    scale = system[2] if system[0] == "primal" else 1.0  # eig(J^T J) = scale eig(S)
    if ratio > 0 and not dense:
        S = system[1]
        r = ratio / scale
        A = np.array(S, order="F")
        A.flat[:: len(A) + 1] += r
        U, info = dpotrf(A, lower=0, clean=1, overwrite_a=1)
        if info == 0:
            Ui, info = dtrtri(U, lower=0, overwrite_c=1)
            trace = float(np.vdot(Ui, Ui))  # |U^-1|_F^2 = tr(A^-1)
            if info == 0 and np.isfinite(trace):
                return float(len(S) - r * trace)
    lam = eigvalsh(system[1], lower=False, check_finite=False, overwrite_a=False)
    lam = np.clip(lam * scale, 0.0, None)
    return float(np.sum(lam / (lam + ratio))) if ratio > 0 else float(np.count_nonzero(lam > 0))


def _step(system, JE, theta, ratio, mu, n_e, buf):
    """dtheta minimising |e + J d|^2 + ratio |theta + d|^2 + mu N_e |d|^2 (None if the damped
    matrix is not positive definite), through :func:`lab.learn.lm._lm_step`."""
    if system[0] == "primal":
        return _lm_step(system, JE + (ratio / n_e) * theta, mu + ratio / n_e, n_e, buf)
    # kernel form: with c = ratio + mu N_e and K = J J^T + c I (push-through identity),
    # d = -(ratio / c) theta - J^T K^-1 (e - (ratio / c) J theta)
    c = ratio + mu * n_e
    J, e = system[2], system[3]
    d = _lm_step(("kernel", system[1], J, e - (ratio / c) * (J @ theta)), JE, c / n_e, n_e, buf)
    return None if d is None else d - (ratio / c) * theta


def _systems(net, u, y, max_mb, dense=False, work=None):
    perf, JE, system = _jacobian_products(net, u, y, max_mb, dense, work)
    if system[0] == "primal":
        system = (*system, y.size)  # the eigenvalues of J^T J are N_e times those stored
    return perf, JE, system


def _hyper(gamma: float, sse: float, ssw: float, n_e: int) -> tuple[float, float]:
    """alpha = gamma / (2 E_W), beta = (N_e - gamma) / (2 E_D); guarded against 0 / 0."""
    alpha = gamma / (2.0 * ssw) if ssw > 0 else 1.0
    beta = (n_e - gamma) / (2.0 * sse) if sse > 0 else np.inf
    return alpha, beta


def train_br(model: MLP, data: TrainingData, options: BROptions | None = None, progress=None) -> tuple[MLP, TrainLog]:
    """Bayesian-regularised Levenberg-Marquardt (``trainbr``).

    Parameters
    ----------
    model : MLP
        The initial network (not changed; a copy is trained).
    data : TrainingData
        Training set (N, n_u) rad -> (N, n_y) m; the validation and test sets are only
        recorded.
    options : BROptions, optional
        Default ``BROptions()`` (``max_fail`` is ignored).
    progress : callable, optional
        ``progress(epoch, history_row)``, called once per epoch.

    Returns
    -------
    MLP
        The last network.
    TrainLog
        Per epoch ``perf`` (training MSE, m^2), ``vperf``, ``tperf``, ``mu``, ``gradient``,
        ``gamma``, ``alpha``, ``beta`` (1/m^2) and ``ssw`` (E_W); :func:`br_summary`
        condenses it.
    """
    opt = _checked(options, BROptions)
    _arrays(data)
    with blas_threads(data.y_train.size, model.n_params):
        return _train_br(model, data, opt, progress)


def _train_br(model, data, opt, progress):
    t0 = time.perf_counter()
    net = model.copy()
    u_train, y_train, u_val, y_val, u_test, y_test = _arrays(data)
    n_e, n_p = y_train.size, net.n_params
    theta = net.get_params()
    dense, work = opt.dense_reference, {}  # work: gauss_newton's arrays, kept across epochs
    perf, JE, system = _systems(net, u_train, y_train, opt.max_jacobian_mb, dense, work)
    buf = np.empty_like(system[1], order="F")
    ssw = float(theta @ theta)
    gamma = min(float(n_p), 0.5 * n_e)
    alpha, beta = _hyper(gamma, perf * n_e, ssw, n_e)
    mu, hist, stop = opt.mu, [], None
    for epoch in range(opt.epochs + 1):
        ratio = alpha / beta
        grad_F = JE + (ratio / n_e) * theta  # gradient of (E_D + r E_W) / N_e, halved
        gradient = 2.0 * float(np.linalg.norm(grad_F))
        if perf <= opt.goal:
            stop = "goal"
        elif epoch == opt.epochs:
            stop = "max_epochs"
        elif gradient <= opt.min_grad:
            stop = "min_grad"
        elif mu >= opt.mu_max:
            stop = "mu_max"
        row = (epoch, perf, mse(net, u_val, y_val), mse(net, u_test, y_test), mu, gradient, gamma, alpha, beta, ssw)
        hist.append(row)
        if progress is not None:
            progress(epoch, row)
        if stop:
            break
        objective = perf * n_e + ratio * ssw  # E_D + r E_W, m^2
        while mu <= opt.mu_max:
            step = _step(system, JE, theta, ratio, mu, n_e, buf)
            if step is not None:
                trial = theta + step
                net.set_params(trial)
                if mse(net, u_train, y_train) * n_e + ratio * float(trial @ trial) < objective:
                    theta = trial
                    mu = max(mu * opt.mu_dec, 1e-20)
                    break
            mu *= opt.mu_inc
        net.set_params(theta)
        perf, JE, system = _systems(net, u_train, y_train, opt.max_jacobian_mb, dense, work)
        ssw = float(theta @ theta)
        if mu <= opt.mu_max:  # an accepted step: re-estimate the hyperparameters there
            gamma = effective_parameters(system, ratio, dense)
            alpha, beta = _hyper(gamma, perf * n_e, ssw, n_e)
    cols = ("epoch", "perf", "vperf", "tperf", "mu", "gradient", "gamma", "alpha", "beta", "ssw")
    history = {c: np.array([row[i] for row in hist]) for i, c in enumerate(cols)}
    epochs = int(hist[-1][0])
    return net, TrainLog("br", stop, epochs, epochs, history, asdict(opt), time.perf_counter() - t0)


def br_summary(log: TrainLog, n_params: int) -> dict:
    """The final hyperparameters of a :func:`train_br` log, for a model's training metadata:
    ``alpha`` (1 / unit weight^2), ``beta`` (1/m^2), ``gamma`` (effective parameters),
    ``n_params``, ``noise_std_m`` = 1 / sqrt(2 beta) (estimated noise per coordinate) and
    ``sum_squared_weights`` (E_W)."""
    h = log.history
    beta = float(h["beta"][-1])
    finite = bool(np.isfinite(beta) and beta > 0)  # infinite when the data are fitted exactly
    return {
        "alpha": float(h["alpha"][-1]),
        "beta": beta if finite else None,
        "gamma": float(h["gamma"][-1]),
        "n_params": int(n_params),
        "noise_std_m": float(1.0 / np.sqrt(2.0 * beta)) if finite else 0.0,
        "sum_squared_weights": float(h["ssw"][-1]),
    }
