"""One entry point for training the forward model: split, initialise, fit.

:func:`train` draws a ``dividerand`` split (:mod:`lab.learn.split`) and Nguyen-Widrow
initial weights (:func:`lab.learn.mlp_init.init_mlp`) from one seeded random stream, so a seed
fixes everything, then fits with MATLAB-faithful Levenberg-Marquardt
(:mod:`lab.learn.lm`, the default) or Adam / L-BFGS (:mod:`lab.learn.gradient`), and
records what is needed to reproduce the run in the model's metadata.
"""

from __future__ import annotations

import hashlib
from dataclasses import asdict, dataclass, replace
from typing import Protocol

import numpy as np

from lab.errors import InputError
from lab.learn.algorithm_choice import choose_algorithm
from lab.learn.bayes import BROptions, br_summary, train_br
from lab.learn.gradient import AdamOptions, LBFGSOptions, train_adam, train_lbfgs
from lab.learn.lm import STOP_MESSAGES, LMOptions, TrainLog, train_lm
from lab.learn.lm_subsample import LMSubsampleOptions, train_lm_subsample
from lab.learn.metrics import error_report
from lab.learn.mlp import MLP
from lab.learn.mlp_init import init_mlp
from lab.learn.network_size import check_network_size
from lab.learn.split import Split, check_enough_data, divide
from lab.learn.training_data import TrainingData

#: The trainers; ``auto`` picks ``lm`` or ``lm-subsample`` by size
#: (:func:`lab.learn.algorithm_choice.choose_algorithm`).
ALGORITHMS = ("lm", "adam", "lbfgs", "br", "lm-subsample", "auto")

#: algorithm -> the type of its options (``auto``: LM's, carried over to ``lm-subsample``)
ALGORITHM_OPTIONS = {
    "lm": LMOptions,
    "adam": AdamOptions,
    "lbfgs": LBFGSOptions,
    "br": BROptions,
    "lm-subsample": LMSubsampleOptions,
    "auto": LMOptions,
}


class EpochProgress(Protocol):
    """What every trainer (:func:`train`, and the LM, BR, Adam and L-BFGS loops it runs)
    calls once per epoch: epoch 0 with the initial network, then after each epoch, the last
    call with the epoch it stopped at. The call only observes: the weights and their
    history are the same with or without one.

    Parameters
    ----------
    epoch : int
        (of the call) Epochs done, 0 .. the maximum.
    row : tuple
        (of the call) The trainer's history row of this epoch.
    """

    def __call__(self, epoch: int, row: tuple) -> None:
        """Told that ``epoch`` is done.

        Parameters
        ----------
        epoch : int
            Epochs done, 0 .. the maximum.
        row : tuple
            The trainer's history row of this epoch (its ``TrainLog.history`` columns).
        """


def max_epochs(algorithm: str, epochs: int | None = None, options=None) -> int:
    """The most epochs :func:`train` runs with these settings (it may stop earlier).

    Parameters
    ----------
    algorithm : str
        One of ``ALGORITHMS``.
    epochs : int, optional
        :func:`train`'s ``epochs`` (overrides the options').
    options : LMOptions, BROptions, AdamOptions or LBFGSOptions, optional
        The algorithm's options (None: its defaults).

    Returns
    -------
    int
        The epoch limit.
    """
    if epochs is not None:
        return int(epochs)
    return int((options if options is not None else ALGORITHM_OPTIONS[algorithm]()).epochs)


def check_options(algorithm: str, options) -> None:
    """Refuse options that are not ``algorithm``'s options type.

    Parameters
    ----------
    algorithm : str
        One of ``ALGORITHMS``.
    options : LMOptions, BROptions, AdamOptions, LBFGSOptions or None
        None (the algorithm's defaults) or an object of ``ALGORITHM_OPTIONS`` ``[algorithm]``.

    Returns
    -------
    None

    Raises
    ------
    InputError
        For an unknown algorithm or options of another type.
    """
    if algorithm not in ALGORITHMS:
        raise InputError(f"algorithm must be one of {ALGORITHMS}, got {algorithm!r}")
    want = ALGORITHM_OPTIONS[algorithm]
    if options is not None and type(options) is not want:
        raise InputError(f"algorithm {algorithm!r} takes options of type {want.__name__}, got {type(options).__name__}")


def data_sha256(u: np.ndarray, y: np.ndarray) -> str:
    """SHA-256 of the training data as float64 arrays (shapes included), independent of file format.

    Parameters
    ----------
    u : numpy.ndarray
        Inputs, shape (N, n_u), rad.
    y : numpy.ndarray
        Outputs, shape (N, n_y), m.

    Returns
    -------
    str
        The hex digest.
    """
    h = hashlib.sha256()
    for a in (np.ascontiguousarray(u, dtype="<f8"), np.ascontiguousarray(y, dtype="<f8")):
        h.update(repr(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()


@dataclass
class TrainResult:
    """A trained network with its split, log and errors.

    Attributes
    ----------
    model : MLP
        The trained network (best validation epoch), its record in ``metadata["training"]``.
    split : Split
        The rows of the training, validation and test sets.
    log : TrainLog
        What the trainer did.
    errors : dict
        ``errors[set]`` = {``mse_m2`` (m^2), ``mean_distance_m`` (m), ``n``} for
        ``train``, ``validation``, ``test``.
    """

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
    progress: EpochProgress | None = None,
    init=None,
    groups=None,
) -> TrainResult:
    """Split (``dividerand``), initialise (Nguyen-Widrow) and train a u -> y network.

    One random stream seeded by ``seed`` draws the split, then the initial weights (then,
    for Adam, the shuffles). The model's ``metadata["training"]`` records everything needed
    to reproduce the run; for "br" also alpha, beta and gamma
    (``metadata["training"]["bayesian_regularisation"]``).

    Parameters
    ----------
    u : array_like, shape (N, n_u)
        Inputs (commands, rad).
    y : array_like, shape (N, n_y)
        Targets (tip positions, m).
    hidden : tuple of int
        Hidden layer widths.
    activation : str
        Hidden activation, one of ``lab.learn.mlp.ACTIVATIONS``.
    algorithm : str
        "lm" (:func:`lab.learn.lm.train_lm`), "br" (Bayesian regularisation,
        :func:`lab.learn.bayes.train_br`), "adam" or "lbfgs" (:mod:`lab.learn.gradient`),
        "lm-subsample" (:func:`lab.learn.lm_subsample.train_lm_subsample`) or "auto" (one of
        the two LMs by size, :func:`lab.learn.algorithm_choice.choose_algorithm`, recorded as
        ``metadata["training"]["algorithm_choice"]``).
    ratios : tuple of float
        (train, validation, test) split ratios.
    seed : int
        Seed of the random stream.
    epochs : int, optional
        Overrides the options' maximum number of epochs.
    options : LMOptions, BROptions, AdamOptions, LBFGSOptions or LMSubsampleOptions, optional
        The algorithm's options (``ALGORITHM_OPTIONS``); None: its defaults. Another
        type is an InputError.
    progress : EpochProgress, optional
        ``progress(epoch, history_row)``, called once per epoch (:class:`EpochProgress`).
    init : MLP, optional
        A network of the same input and output sizes to continue from instead of
        Nguyen-Widrow weights (a copy is trained; the split is drawn as without it).
    groups : array_like, shape (N,), optional
        Hold out whole groups (measurement sequences) instead,
        :func:`lab.learn.split.divide_groups`.

    Returns
    -------
    TrainResult
        The network, its split, the training log and its errors per set.
    """
    u, y = np.asarray(u, dtype=float), np.asarray(y, dtype=float)
    if u.ndim != 2 or y.ndim != 2 or len(u) != len(y):
        raise InputError(f"expected u (N, n_u) and y (N, n_y) with the same N, got {u.shape} and {y.shape}")
    check_options(algorithm, options)
    if epochs is not None and epochs < 1:
        raise InputError(f"epochs must be positive, got {epochs}")
    check_enough_data(u, ratios)
    rng = np.random.default_rng(seed)
    split = divide(len(u), ratios, rng, groups)
    sizes = init.layer_sizes if init is not None else (u.shape[1], *hidden, y.shape[1])
    choice = None
    if algorithm == "auto":
        algorithm, choice = choose_algorithm(sizes, len(split.train))
        if options is not None and algorithm == "lm-subsample":  # LM's settings that were changed
            default = asdict(type(options)())
            options = LMSubsampleOptions(**{k: v for k, v in asdict(options).items() if v != default[k]})
    check_network_size(sizes, len(split.train), algorithm)  # before allocating any weight
    model = init_mlp(u, y, hidden, activation, rng)
    if init is not None:
        if (init.n_u, init.n_y) != (u.shape[1], y.shape[1]):
            raise InputError(
                f"init maps {init.n_u} inputs to {init.n_y} outputs; the data have {u.shape[1]} and {y.shape[1]}"
            )
        model = init.copy()
    data = TrainingData.of_split(u, y, split)
    sets = data.sets()
    opt = options if options is not None else ALGORITHM_OPTIONS[algorithm]()
    if epochs is not None:
        opt = replace(opt, epochs=epochs)
    if algorithm in ("adam", "lm-subsample"):  # they draw from the stream too
        fit = train_adam if algorithm == "adam" else train_lm_subsample
        model, log = fit(model, data, opt, seed=rng, progress=progress)
    else:
        fit = {"lm": train_lm, "br": train_br, "lbfgs": train_lbfgs}[algorithm]
        model, log = fit(model, data, opt, progress=progress)
    errors = {name: error_report(model, *sets[name]) for name in sets}
    model.metadata["training"] = {
        "algorithm": log.algorithm,
        **({"algorithm_choice": choice} if choice else {}),
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
        model.metadata["training"]["bayesian_regularisation"] = br_summary(log, model.n_params)
    model.metadata["units"] = {"u": "rad", "y": "m"}
    return TrainResult(model, split, log, errors)
