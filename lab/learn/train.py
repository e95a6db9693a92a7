"""One entry point for training the forward model: split, initialise, fit.

:func:`train` draws a ``dividerand`` split (:mod:`lab.learn.split`) and Nguyen-Widrow
initial weights (:func:`lab.learn.mlp.init_mlp`) from one seeded random stream, so a seed
fixes everything, then fits with MATLAB-faithful Levenberg-Marquardt
(:mod:`lab.learn.lm`, the default) or Adam / L-BFGS (:mod:`lab.learn.gradient`), and
records what is needed to reproduce the run in the model's metadata.
"""

from __future__ import annotations

import hashlib
from dataclasses import asdict, dataclass

import numpy as np

from lab.errors import InputError
from lab.learn.lm import STOP_MESSAGES, LMOptions, TrainLog, train_lm
from lab.learn.metrics import error_report
from lab.learn.mlp import MLP, init_mlp
from lab.learn.network_size import check_network_size
from lab.learn.split import Split, check_enough_data, divide

ALGORITHMS = ("lm", "adam", "lbfgs", "br")


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
    init=None,
    groups=None,
) -> TrainResult:
    """Split (``dividerand``), initialise (Nguyen-Widrow) and train a u -> y network.

    ``u`` (N, n_u), ``y`` (N, n_y); ``ratios`` (train, validation, test); one random stream
    seeded by ``seed`` draws the split, then the initial weights. ``algorithm``: "lm"
    (:func:`train_lm`, ``options`` an :class:`LMOptions`), "br" (Bayesian regularisation,
    :func:`lab.learn.bayes.train_br`, ``options`` an :class:`LMOptions`, default
    :func:`lab.learn.bayes.br_options`; alpha, beta, gamma go to
    ``metadata["training"]["bayesian_regularisation"]``), "adam" or "lbfgs"
    (:mod:`lab.learn.gradient`, ``options`` a dict of keyword arguments). ``epochs``
    overrides the maximum number of epochs. The model's ``metadata["training"]`` records
    everything needed to reproduce the run. ``init``: an :class:`MLP` of the same input and
    output sizes to continue from instead of Nguyen-Widrow weights (a copy is trained; the
    split is drawn as without it), e.g. to extend a long run by more epochs. ``groups`` (N,):
    hold out whole groups (measurement sequences) instead, :func:`lab.learn.split.divide_groups`.
    """
    u, y = np.asarray(u, dtype=float), np.asarray(y, dtype=float)
    if u.ndim != 2 or y.ndim != 2 or len(u) != len(y):
        raise InputError(f"expected u (N, n_u) and y (N, n_y) with the same N, got {u.shape} and {y.shape}")
    if algorithm not in ALGORITHMS:
        raise InputError(f"algorithm must be one of {ALGORITHMS}, got {algorithm!r}")
    if epochs is not None and epochs < 1:
        raise InputError(f"epochs must be positive, got {epochs}")
    check_enough_data(u, ratios)
    rng = np.random.default_rng(seed)
    split = divide(len(u), ratios, rng, groups)
    sizes = init.layer_sizes if init is not None else (u.shape[1], *hidden, y.shape[1])
    check_network_size(sizes, len(split.train), algorithm)  # before allocating any weight
    model = init_mlp(u, y, hidden, activation, rng)
    if init is not None:
        if (init.n_u, init.n_y) != (u.shape[1], y.shape[1]):
            raise InputError(
                f"init maps {init.n_u} inputs to {init.n_y} outputs; the data have {u.shape[1]} and {y.shape[1]}"
            )
        model = init.copy()
    sets = {
        name: (u[idx], y[idx])
        for name, idx in (("train", split.train), ("validation", split.validation), ("test", split.test))
    }
    args = (*sets["train"], *sets["validation"], *sets["test"])
    if algorithm in ("lm", "br"):
        from lab.learn.bayes import br_options, train_br

        opt = options or (LMOptions() if algorithm == "lm" else br_options())
        if epochs is not None:
            opt = LMOptions(**{**asdict(opt), "epochs": epochs})
        model, log = (train_lm if algorithm == "lm" else train_br)(model, *args, options=opt, progress=progress)
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
        **({"init": init.metadata.get("training", {}).get("command", "a given network")} if init is not None else {}),
        "split": {
            "method": "dividerand" if groups is None else "group",
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
    if algorithm == "br":  # the evidence's hyperparameters, alpha, beta, gamma
        from lab.learn.bayes import br_summary

        model.metadata["training"]["bayesian_regularisation"] = br_summary(log, model.n_params)
    model.metadata["units"] = {"u": "rad", "y": "m"}
    return TrainResult(model, split, log, errors)
