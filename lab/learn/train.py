"""Training the forward model: data splits, MATLAB-faithful Levenberg-Marquardt, one entry point.

The paper trained its networks with MATLAB's Deep Learning Toolbox (``feedforwardnet`` +
``trainlm``). :func:`train_lm` reproduces ``trainlm`` with its parameters

    mu = 1e-3, mu_dec = 0.1, mu_inc = 10, mu_max = 1e10, epochs = 1000,
    max_fail = 6, min_grad = 1e-6 (the paper's value; MATLAB's default is 1e-7), goal = 0

and its semantics, epoch by epoch:

1. **Stop checks**, in MATLAB's order: performance goal met, maximum epoch reached,
   gradient ``2 |J^T e| / N_e`` below ``min_grad``, ``mu >= mu_max``, or ``max_fail``
   consecutive validation failures. Whatever the reason, the network returned is the
   **best one seen**: lowest validation MSE (lowest training MSE without a validation set).
2. **Step**: solve ``(J^T J / N_e + mu I) dtheta = -J^T e / N_e`` (Cholesky). If the
   training MSE decreases, accept and set ``mu <- max(mu * mu_dec, 1e-20)``; otherwise
   ``mu <- mu * mu_inc`` and retry, until ``mu > mu_max``. A matrix that is not
   numerically positive definite counts as a failed trial (MATLAB: singular-matrix warning).
3. **Validation**: MSE on the validation set; lower than the best so far -> new best and
   ``val_fail = 0``; higher -> ``val_fail += 1``; equal -> unchanged.

Errors ``e = y(u) - y_data`` are in the data's units (metres), the performance is MATLAB's
``mse`` (mean over samples *and* coordinates, ``N_e = N * n_y`` elements), as with
``feedforwardnet``'s default ``performParam.normalization = 'none'``. The Jacobian
``J = d y / d theta`` comes in closed form from :meth:`lab.learn.mlp.MLP.parameter_jacobian`.
When there are more parameters than residuals the identical step is computed in the
kernel form ``dtheta = -J^T (J J^T + mu N_e I)^{-1} e`` (cheaper: an N_e x N_e system).

Splits follow MATLAB ``dividerand``: a random permutation, ``round(ratio * N)`` samples
for validation and test, the rest for training. :func:`train` does split + init + fit
with one seeded random stream, so a seed fixes everything. Adam and L-BFGS for large
datasets live in :mod:`lab.learn.gradient`; error metrics and studies in :mod:`lab.learn.studies`.
"""

from __future__ import annotations

import hashlib
from dataclasses import asdict, dataclass

import numpy as np

from lab.errors import InputError
from lab.learn.lm import STOP_MESSAGES, LMOptions, TrainLog, train_lm
from lab.learn.metrics import error_report
from lab.learn.mlp import MLP, init_mlp
from lab.learn.split import Split, divide_random

ALGORITHMS = ("lm", "adam", "lbfgs")


def data_sha256(u: np.ndarray, y: np.ndarray) -> str:
    """SHA-256 of the training data as float64 arrays (shapes included), independent of file format."""
    h = hashlib.sha256()
    for a in (np.ascontiguousarray(u, dtype="<f8"), np.ascontiguousarray(y, dtype="<f8")):
        h.update(repr(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()


@dataclass
class TrainResult:
    """A trained network with its split, log and errors (``errors[set]`` = {mse_m2, mean_distance_m, n})."""

    model: MLP
    split: Split
    log: TrainLog
    errors: dict


def train(
    u,
    y,
    hidden=(20, 20),
    *,
    activation: str = "tanh",
    algorithm: str = "lm",
    ratios=(0.8, 0.1, 0.1),
    seed: int = 0,
    epochs: int | None = None,
    options=None,
    progress=None,
) -> TrainResult:
    """Split (``dividerand``), initialise (Nguyen-Widrow) and train a u -> y network.

    ``u`` (N, n_u), ``y`` (N, n_y); ``ratios`` (train, validation, test); one random stream
    seeded by ``seed`` draws the split, then the initial weights. ``algorithm``: "lm"
    (:func:`train_lm`, ``options`` an :class:`LMOptions`), "adam" or "lbfgs"
    (:mod:`lab.learn.gradient`, ``options`` a dict of keyword arguments). ``epochs``
    overrides the maximum number of epochs. The model's ``metadata["training"]`` records
    everything needed to reproduce the run.
    """
    u, y = np.asarray(u, dtype=float), np.asarray(y, dtype=float)
    if u.ndim != 2 or y.ndim != 2 or len(u) != len(y):
        raise InputError(f"expected u (N, n_u) and y (N, n_y) with the same N, got {u.shape} and {y.shape}")
    if algorithm not in ALGORITHMS:
        raise InputError(f"algorithm must be one of {ALGORITHMS}, got {algorithm!r}")
    if epochs is not None and epochs < 1:
        raise InputError(f"epochs must be positive, got {epochs}")
    rng = np.random.default_rng(seed)
    split = divide_random(len(u), ratios, rng)
    model = init_mlp(u, y, hidden, activation, rng)
    sets = {
        name: (u[idx], y[idx])
        for name, idx in (("train", split.train), ("validation", split.validation), ("test", split.test))
    }
    args = (*sets["train"], *sets["validation"], *sets["test"])
    if algorithm == "lm":
        opt = options or LMOptions()
        if epochs is not None:
            opt = LMOptions(**{**asdict(opt), "epochs": epochs})
        model, log = train_lm(model, *args, options=opt, progress=progress)
    else:
        from lab.learn.gradient import train_adam, train_lbfgs

        kwargs = dict(options or {})
        if epochs is not None:
            kwargs["epochs"] = epochs
        fit = train_adam if algorithm == "adam" else train_lbfgs
        if algorithm == "adam":
            kwargs.setdefault("seed", rng)
        model, log = fit(model, *args, progress=progress, **kwargs)
    errors = {name: error_report(model, *sets[name]) for name in sets}
    model.metadata["training"] = {
        "algorithm": log.algorithm,
        "options": {k: v for k, v in log.options.items() if k != "seed"},
        "epochs": log.epochs,
        "best_epoch": log.best_epoch,
        "stop_reason": log.stop_reason,
        "stop_message": STOP_MESSAGES.get(log.stop_reason, log.stop_reason),
        "seed": seed,
        "split": {
            "method": "dividerand",
            "ratios": list(map(float, ratios)),
            **split.sizes(),
            "indices": {
                "train": split.train.tolist(),
                "validation": split.validation.tolist(),
                "test": split.test.tolist(),
            },
        },
        "errors": errors,
        "data_sha256": data_sha256(u, y),
        "n_samples": len(u),
        "wall_s": log.wall_s,
    }
    model.metadata["units"] = {"u": "rad", "y": "m"}
    return TrainResult(model, split, log, errors)
