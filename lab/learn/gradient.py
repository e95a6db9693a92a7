"""First-order and quasi-Newton training for large datasets: Adam and L-BFGS.

Levenberg-Marquardt (:mod:`lab.learn.lm`) needs the (N n_y) x n_params Jacobian and an
n_params^2 system per epoch: ideal for a few hundred samples, costly for tens of
thousands. These two only need the loss gradient, computed by plain backpropagation
(:meth:`lab.learn.mlp.MLP.gradient`, no Jacobian matrix).

The loss they minimise is the MSE in *normalised* output units (``mapminmax`` of y to
[-1, 1]), which is well scaled whatever the data's units; reported errors (``history``)
are in the data's units like those of LM. Early stopping uses the validation set as
``trainlm`` does: ``max_fail`` consecutive epochs (iterations for L-BFGS) whose
validation MSE is worse than the best so far stop training, and the best-validation
weights are returned. Noisier than LM epochs, so ``max_fail`` defaults to 20 here.
"""

from __future__ import annotations

import time

import numpy as np

from lab.learn.lm import TrainLog, mse
from lab.learn.mlp import MLP


def _loss_grad(model: MLP, theta, u, y):
    """Normalised-output MSE and its gradient with respect to theta."""
    model.set_params(theta)
    r = (model.predict(u) - y) * model.y_gain
    n_e = r.size
    return float(np.sum(r * r) / n_e), model.gradient(u, 2.0 * r * model.y_gain / n_e)


class _Tracker:
    """Per-epoch record and best-validation bookkeeping shared by Adam and L-BFGS."""

    def __init__(self, model, u_tr, y_tr, u_val, y_val, u_te, y_te, max_fail, progress):
        self.model, self.data = model, (u_tr, y_tr, u_val, y_val, u_te, y_te)
        self.has_val = u_val is not None and len(u_val) > 0
        self.max_fail, self.progress = max_fail, progress
        self.rows, self.best, self.val_fail = [], None, 0

    def record(self, epoch, theta) -> bool:
        """Record epoch; True when validation says stop."""
        u_tr, y_tr, u_val, y_val, u_te, y_te = self.data
        self.model.set_params(theta)
        perf = mse(self.model, u_tr, y_tr)
        vperf = mse(self.model, u_val, y_val) if self.has_val else float("nan")
        tperf = mse(self.model, u_te, y_te) if u_te is not None and len(u_te) else float("nan")
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
    u_train,
    y_train,
    u_val=None,
    y_val=None,
    u_test=None,
    y_test=None,
    *,
    epochs: int = 1000,
    lr: float = 1e-3,
    batch_size: int = 256,
    beta1: float = 0.9,
    beta2: float = 0.999,
    eps: float = 1e-8,
    max_fail: int = 20,
    seed: int | np.random.Generator = 0,
    progress=None,
) -> tuple[MLP, TrainLog]:
    """Mini-batch Adam (Kingma & Ba) on the normalised MSE; shuffles each epoch with ``seed``."""
    t0 = time.perf_counter()
    net = model.copy()
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    theta = net.get_params()
    m, v, t = np.zeros_like(theta), np.zeros_like(theta), 0
    track = _Tracker(net, u_train, y_train, u_val, y_val, u_test, y_test, max_fail, progress)
    stop = "max_epochs"
    options = {
        "epochs": epochs,
        "lr": lr,
        "batch_size": batch_size,
        "beta1": beta1,
        "beta2": beta2,
        "eps": eps,
        "max_fail": max_fail,
    }
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
    model: MLP,
    u_train,
    y_train,
    u_val=None,
    y_val=None,
    u_test=None,
    y_test=None,
    *,
    epochs: int = 1000,
    max_fail: int = 20,
    gtol: float = 1e-10,
    progress=None,
) -> tuple[MLP, TrainLog]:
    """Full-batch L-BFGS (``scipy.optimize.minimize``, method L-BFGS-B, analytic gradient);
    one "epoch" is one L-BFGS iteration."""
    from scipy.optimize import minimize

    t0 = time.perf_counter()
    net = model.copy()
    track = _Tracker(net, u_train, y_train, u_val, y_val, u_test, y_test, max_fail, progress)
    options = {"epochs": epochs, "max_fail": max_fail, "gtol": gtol}
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
