"""First-order and quasi-Newton training for large datasets: Adam and L-BFGS.

Levenberg-Marquardt (:mod:`lab.learn.lm`) needs J^T J, N n_y n_params^2 multiply-adds, and
an n_params^2 system per epoch: ideal for a few hundred samples, costly for tens of
thousands. These two only need the loss gradient, computed by plain backpropagation
(:meth:`lab.learn.mlp.MLP.gradient`, no Jacobian matrix); on the networks of this lab they
stop at several times LM's error, so the default for large datasets is LM with a sampled
curvature instead (:mod:`lab.learn.lm_subsample`, benchmarks/bench_training.py).

The loss they minimise is the MSE in *normalised* output units (``mapminmax`` of y to
[-1, 1]), which is well scaled whatever the data's units; reported errors (``history``)
are in the data's units like those of LM. Early stopping uses the validation set as
``trainlm`` does: ``max_fail`` consecutive epochs (iterations for L-BFGS) whose
validation MSE is worse than the best so far stop training, and the best-validation
weights are returned. Noisier than LM epochs, so ``max_fail`` defaults to 20 here.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass

import numpy as np

from lab.learn.lm import TrainLog, _arrays, _checked, mse
from lab.learn.mlp import MLP
from lab.learn.training_data import TrainingData

__all__ = ["AdamOptions", "LBFGSOptions", "train_adam", "train_lbfgs"]


@dataclass(frozen=True)
class AdamOptions:
    """Mini-batch Adam's parameters (Kingma & Ba's defaults; ``max_fail`` 20).

    Parameters
    ----------
    epochs : int
        Maximum number of epochs (passes over the shuffled training set).
    lr : float
        Step size (normalised output units per unit gradient).
    batch_size : int
        Samples per step.
    beta1, beta2 : float
        Decay rates of the first and second moment estimates.
    eps : float
        Added to the root of the second moment.
    max_fail : int
        Consecutive epochs of worse validation error that stop training.
    """

    epochs: int = 1000
    lr: float = 1e-3
    batch_size: int = 256
    beta1: float = 0.9
    beta2: float = 0.999
    eps: float = 1e-8
    max_fail: int = 20


@dataclass(frozen=True)
class LBFGSOptions:
    """Full-batch L-BFGS's parameters.

    Parameters
    ----------
    epochs : int
        Maximum number of L-BFGS iterations.
    max_fail : int
        Consecutive iterations of worse validation error that stop training.
    gtol : float
        scipy's projected-gradient stop (normalised loss per unit weight).
    """

    epochs: int = 1000
    max_fail: int = 20
    gtol: float = 1e-10


def _loss_grad(model: MLP, theta, u, y):
    """Normalised-output MSE and its gradient with respect to theta."""
    model.set_params(theta)
    r = (model.predict(u) - y) * model.y_gain
    n_e = r.size
    return float(np.sum(r * r) / n_e), model.gradient(u, 2.0 * r * model.y_gain / n_e)


class _Tracker:
    """Per-epoch record and best-validation bookkeeping shared by Adam and L-BFGS."""

    def __init__(self, model, data: TrainingData, max_fail, progress):
        self.model, self.data = model, _arrays(data)
        self.has_val = data.has_validation
        self.max_fail, self.progress = max_fail, progress
        self.rows, self.best, self.val_fail = [], None, 0

    def record(self, epoch, theta) -> bool:
        """Record epoch; True when validation says stop."""
        u_tr, y_tr, u_val, y_val, u_te, y_te = self.data
        self.model.set_params(theta)
        perf = mse(self.model, u_tr, y_tr)
        vperf = mse(self.model, u_val, y_val) if self.has_val else float("nan")
        tperf = mse(self.model, u_te, y_te) if len(u_te) else float("nan")
        key = vperf if self.has_val else perf
        if self.best is None or key < self.best[0]:
            self.best, self.val_fail = (key, theta.copy(), epoch), 0
        elif self.has_val and key > self.best[0]:
            self.val_fail += 1
        self.rows.append((epoch, perf, vperf, tperf, self.val_fail))
        if self.progress is not None:
            self.progress(epoch, self.rows[-1])
        return self.has_val and self.val_fail >= self.max_fail

    def finish(self, algorithm, stop, options, t0):
        self.model.set_params(self.best[1])
        cols = ("epoch", "perf", "vperf", "tperf", "val_fail")
        history = {c: np.array([r[i] for r in self.rows]) for i, c in enumerate(cols)}
        return self.model, TrainLog(
            algorithm, stop, int(self.rows[-1][0]), int(self.best[2]), history, options, time.perf_counter() - t0
        )


def train_adam(
    model: MLP,
    data: TrainingData,
    options: AdamOptions | None = None,
    *,
    seed: int | np.random.Generator = 0,
    progress=None,
) -> tuple[MLP, TrainLog]:
    """Mini-batch Adam (Kingma & Ba) on the normalised MSE.

    Parameters
    ----------
    model : MLP
        The initial network (not changed; a copy is trained).
    data : TrainingData
        Training set (N, n_u) rad -> (N, n_y) m; the validation set stops training after
        ``max_fail`` worse epochs, the test set is only recorded.
    options : AdamOptions, optional
        Default ``AdamOptions()``.
    seed : int or numpy.random.Generator
        The stream that shuffles the training set each epoch.
    progress : callable, optional
        ``progress(epoch, history_row)``, called once per epoch.

    Returns
    -------
    MLP
        The best-validation network (best training MSE without validation).
    TrainLog
        Per epoch ``epoch``, ``perf``, ``vperf``, ``tperf`` (MSE, m^2) and ``val_fail``.
    """
    opt = _checked(options, AdamOptions)
    epochs, lr, batch_size, beta1, beta2, eps = opt.epochs, opt.lr, opt.batch_size, opt.beta1, opt.beta2, opt.eps
    t0 = time.perf_counter()
    net = model.copy()
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    theta = net.get_params()
    m, v, t = np.zeros_like(theta), np.zeros_like(theta), 0
    track = _Tracker(net, data, opt.max_fail, progress)
    u_train, y_train = data.u_train, data.y_train
    stop = "max_epochs"
    options = asdict(opt)
    if track.record(0, theta):
        stop = "validation"
    for epoch in range(1, epochs + 1):
        if stop == "validation":
            break
        perm = rng.permutation(len(u_train))
        for s in range(0, len(perm), batch_size):
            idx = perm[s : s + batch_size]
            _, g = _loss_grad(net, theta, u_train[idx], y_train[idx])
            t += 1
            m = beta1 * m + (1 - beta1) * g
            v = beta2 * v + (1 - beta2) * g * g
            theta = theta - lr * (m / (1 - beta1**t)) / (np.sqrt(v / (1 - beta2**t)) + eps)
        if track.record(epoch, theta):
            stop = "validation"
    return track.finish("adam", stop, options, t0)


def train_lbfgs(
    model: MLP, data: TrainingData, options: LBFGSOptions | None = None, *, progress=None
) -> tuple[MLP, TrainLog]:
    """Full-batch L-BFGS (``scipy.optimize.minimize``, method L-BFGS-B, analytic gradient);
    one "epoch" is one L-BFGS iteration.

    Parameters
    ----------
    model : MLP
        The initial network (not changed; a copy is trained).
    data : TrainingData
        Training set (N, n_u) rad -> (N, n_y) m; the validation set stops training after
        ``max_fail`` worse iterations, the test set is only recorded.
    options : LBFGSOptions, optional
        Default ``LBFGSOptions()``.
    progress : callable, optional
        ``progress(iteration, history_row)``, called once per iteration.

    Returns
    -------
    MLP
        The best-validation network (best training MSE without validation).
    TrainLog
        Per iteration ``epoch``, ``perf``, ``vperf``, ``tperf`` (MSE, m^2) and ``val_fail``.
    """
    from scipy.optimize import minimize

    opt = _checked(options, LBFGSOptions)
    epochs, gtol = opt.epochs, opt.gtol
    t0 = time.perf_counter()
    net = model.copy()
    track = _Tracker(net, data, opt.max_fail, progress)
    u_train, y_train = data.u_train, data.y_train
    options = asdict(opt)
    theta0 = net.get_params()
    track.record(0, theta0)
    state = {"it": 0, "stop": None}

    def callback(intermediate_result):
        state["it"] += 1
        if track.record(state["it"], intermediate_result.x):
            state["stop"] = "validation"
            raise StopIteration

    res = minimize(
        lambda th: _loss_grad(net, th, u_train, y_train),
        theta0,
        jac=True,
        method="L-BFGS-B",
        callback=callback,
        options={"maxiter": epochs, "gtol": gtol, "ftol": 1e-15, "maxcor": 20},
    )
    stop = state["stop"] or ("max_epochs" if state["it"] >= epochs else f"lbfgs: {res.message}")
    return track.finish("lbfgs", stop, options, t0)
