"""``python -m lab train``: from a dataset file and a :class:`TrainSpec` to a fitted model.

:func:`run` reads a dataset (and any ``extra_data`` of the same robot, appended before the
split; :func:`lab.learn.run_inputs.read_all`), fits the spec's model -- the network by
:func:`lab.learn.train.train`; any other model on the training part of the same split
(same seed, same indices), with its errors on all three parts and, for an ensemble, its
spread scale fitted on the validation part -- and records where the data came from in the
model's metadata, with the per-motor box of the training commands
(:func:`lab.learn.history.record_data_bounds`), the model's history K and, for a robot
without an FEM (``robot.kind == "measured"``), the sidecar's robot. With ``history`` K > 0
it fits on :func:`lab.learn.history.history_features` of the dataset's sequences; a
``group`` split deals out whole sequences (:func:`lab.learn.split.split_groups`). The spec
is checked against the data (sizes, memory, K below the longest sequence) before any fit.
The command line (:mod:`lab.cli.train`) writes the model and prints :class:`TrainRun`.
"""

from __future__ import annotations

import hashlib
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from lab.errors import InputError
from lab.learn.metrics import workspace_size_m
from lab.learn.models import fit_model, held_out_errors, load_model, net_options, outer_split
from lab.learn.outputs import dataset_io
from lab.learn.run_inputs import forward_model, inputs_and_groups, read_all, record_trained
from lab.learn.split import check_enough_data, thin_training_note
from lab.learn.train import EpochProgress, data_sha256, max_epochs, train
from lab.learn.train_spec import TrainSpec

__all__ = ["TrainSpec", "TrainRun", "run", "network_words"]


@dataclass
class TrainRun:
    """What :func:`run` returns: a fitted model and how it did.

    Parameters
    ----------
    spec : TrainSpec
        The spec the model was fitted with (hidden widths those of ``init``'s network).
    model : object
        The fitted model (an MLP, ensemble, inverse or peer), with its metadata.
    errors : dict
        Per set (train, validation, test): ``{mse_m2, mean_distance_m, n, ...}``.
    calibration : dict or None
        Test calibration of the spread (ensemble, gpr); None for other models.
    stop : dict
        ``stop_reason``, ``epochs``, ``best_epoch`` (None for a model other than the network).
    wall_s : float
        Fit time, s.
    workspace_size_m : float
        Bounding-box diagonal of the tip data, m (NaN if unknown).
    data : str
        The dataset file.
    file_sha256 : str
        SHA-256 of the dataset file.
    split_info : dict
        The report's keys about history and split (``history``, ``split_method``, ...).
    """

    spec: TrainSpec
    model: object
    errors: dict
    calibration: dict | None
    stop: dict
    wall_s: float
    workspace_size_m: float
    data: str
    file_sha256: str
    split_info: dict

    def report(self, model_path) -> dict:
        """The JSON report of ``train --report`` (kind ``lab.train_report``).

        Parameters
        ----------
        model_path : str or Path
            Where the model was written, recorded as ``model``.

        Returns
        -------
        dict
            The report: errors per set, workspace size (m), data and model provenance,
            training settings, stop record and wall time (s).
        """
        from lab.files import code_version

        size, training = self.workspace_size_m, self.model.metadata["training"]
        net = getattr(self.model, "net", self.model)
        report = {
            "kind": "lab.train_report",
            "format_version": 1,
            **self.errors,
            "workspace_size_m": size if np.isfinite(size) else None,
            "model": str(model_path),
            "model_type": self.spec.model,
            "data": str(self.data),
            "data_file_sha256": self.file_sha256,
            "data_sha256": training["data_sha256"],
            "layer_sizes": list(net.layer_sizes) if hasattr(net, "layer_sizes") else None,
            "activation": self.spec.activation,
            "algorithm": self.spec.algorithm,
            "seed": self.spec.seed,
            "split": list(self.spec.ratios),
            **self.split_info,
            **self.stop,
            "wall_s": self.wall_s,
            "code_version": code_version(),
        }
        if "algorithm_choice" in training:
            report["algorithm_choice"] = training["algorithm_choice"]
        if self.spec.algorithm == "br" and "bayesian_regularisation" in training:
            report["bayesian_regularisation"] = training["bayesian_regularisation"]
        if self.calibration is not None:
            report["calibration_test"] = self.calibration
        return report


def network_words(spec: TrainSpec, n_u: int, n_y: int) -> str:
    """How the log names the spec's network, e.g. "3-20-20-3", "5 x 3-20-20-3"; "" for a peer.

    Parameters
    ----------
    spec : TrainSpec
        The model and its hidden widths.
    n_u, n_y : int
        Inputs and outputs of the network.

    Returns
    -------
    str
        The words.
    """
    net = "-".join(map(str, [n_u, *spec.hidden, n_y]))
    return {"mlp": net, "ensemble": f"{spec.members} x {net}", "inverse-mlp": f"inverse {net}"}.get(spec.model, "")


def _finite_or_none(d: dict) -> dict:
    return {k: (None if isinstance(v, float) and not np.isfinite(v) else v) for k, v in d.items()}


def _fit_other(spec: TrainSpec, u, y, forward, groups=None, progress=None):
    """A model other than the plain network on the training part of train's own split
    (of ``groups`` when given); returns (model, errors per set, calibration or None,
    wall_s, training indices)."""
    from lab.learn.spread_calibration import calibration

    check_enough_data(u, spec.ratios)
    split = outer_split(len(u), spec.ratios, spec.seed, groups)
    t0 = time.perf_counter()
    model = fit_model(spec.model_spec(), u[split.train], y[split.train], progress=progress)
    wall_s = time.perf_counter() - t0
    sets = {"train": split.train, "validation": split.validation, "test": split.test}
    cal = None
    if spec.model in ("ensemble", "gpr") and len(split.test):
        u_t, y_t = u[split.test], y[split.test]
        if spec.model == "ensemble":
            cal = {"raw": calibration(y_t, *model.predict_with_std(u_t, scaled=False))}
            if len(split.validation):
                model.fit_spread_scale(u[split.validation], y[split.validation])
                cal["scaled"] = calibration(y_t, *model.predict_with_std(u_t))
                cal["spread_scale"] = model.spread_scale
        else:
            cal = {"raw": calibration(y_t, *model.predict_with_std(u_t))}
    errors = {name: _finite_or_none(held_out_errors(model, u[idx], y[idx], forward)) for name, idx in sets.items()}
    model.metadata.setdefault("training", {}).update(
        {
            "model": spec.model,
            "seed": spec.seed,
            "split": {
                "method": "dividerand" if groups is None else "group",
                "ratios": list(map(float, spec.ratios)),
                **split.sizes(),
                "indices": {k: v.tolist() for k, v in sets.items()},
            },
            "errors": errors,
            "wall_s": wall_s,
        }
    )
    if cal is not None:
        model.metadata["training"]["calibration_test"] = cal
    return model, errors, cal, wall_s, split.train


def run(spec: TrainSpec, data, *, extra_data=(), init=None, forward=None, command: str = "", log=None,
        progress=None) -> TrainRun:  # fmt: skip
    """Fit ``spec``'s model on a dataset file.

    Parameters
    ----------
    spec : TrainSpec
        The model and how it is trained (:class:`lab.learn.train_spec.TrainSpec`).
    data : str or Path
        Dataset CSV (``u0..,x,y,z`` and ``NAME_x,NAME_y,NAME_z`` per further marker; metres)
        with its ``.json`` sidecar; the model predicts every marker's output columns.
    extra_data : sequence of str or Path
        More datasets of the same robot, appended to ``data`` before the split.
    init : str or Path, optional
        A network file to continue (``model="mlp"`` only; the spec's hidden widths become its own).
    forward : str or Path, optional
        A forward model file judging a direct inverse's commands (``model="inverse-mlp"``).
    command : str
        The command line, recorded in the model's metadata.
    log : callable, optional
        Called with each progress line.
    progress : callable, optional
        ``progress(done, total)``: ``done`` of at most ``total`` epochs trained, called once
        per epoch (from 0) of a network (``model="mlp"``); other models do not call it.

    Returns
    -------
    TrainRun
        The fitted model with its errors per set, calibration, stop record and timing.
        InputError for bad files, data or settings, before any fit.
    """
    from lab.learn.mlp import MLP

    u, y, meta, extra, ids = read_all(data, extra_data)
    io = dataset_io(meta, u.shape[1], y.shape[1], str(data))
    x, groups, split_info = inputs_and_groups(spec, u, ids, data, log)
    forward_net = forward_model(spec, forward)
    init_model = None
    if init is not None:
        init_model = load_model(init)
        if spec.model != "mlp" or not isinstance(init_model, MLP):
            raise InputError(f"--init {init}: continues an mlp (lab.mlp file) with TrainSpec.model mlp only")
        spec = spec.replace(hidden=tuple(init_model.hidden))
    spec, choice = spec.resolved(x.shape[1], y.shape[1], len(u))  # auto: lm or lm-subsample by size
    spec.check_fits(x.shape[1], y.shape[1], len(u))
    what = network_words(spec, x.shape[1], y.shape[1])
    if log is not None:
        past = f" (history {spec.history}: {u.shape[1]} motors x {spec.history + 1} commands)" if spec.history else ""
        why = f" ({choice})" if choice else ""
        log(
            f"{' + '.join(map(str, [data, *extra_data]))}: {len(u)} samples, {x.shape[1]} inputs{past} -> "
            f"{y.shape[1]} outputs; training {spec.model}"
            f"{f' {what} ({spec.activation}) with {spec.algorithm}{why}' if what else ''}, "
            f"{spec.split} split {list(spec.ratios)}, seed {spec.seed}"
        )
    cal = None
    if spec.model == "mlp":
        options = net_options(spec.algorithm, spec.min_grad)
        on_epoch: EpochProgress | None = None
        if progress is not None:
            total = max_epochs(spec.algorithm, spec.epochs, options)

            def tell(epoch: int, row: tuple) -> None:
                progress(epoch, total)

            on_epoch = tell

        res = train(x, y, spec.hidden, activation=spec.activation, algorithm=spec.algorithm, ratios=spec.ratios,
                    seed=spec.seed, epochs=spec.epochs, options=options, init=init_model, groups=groups,
                    progress=on_epoch)  # fmt: skip
        model, errors, wall_s, train_idx = res.model, res.errors, res.log.wall_s, res.split.train
        stop = {"stop_reason": res.log.stop_reason, "epochs": res.log.epochs, "best_epoch": res.log.best_epoch}
    else:
        model, errors, cal, wall_s, train_idx = _fit_other(spec, x, y, forward_net, groups, progress)
        stop = {"stop_reason": None, "epochs": None, "best_epoch": None}
    record_trained(model, spec, u, train_idx, meta, io)
    if groups is not None:  # whole sequences of unequal length may leave training a sliver
        split_info["split_warning"] = thin_training_note(len(train_idx), len(u), spec.ratios)
        if split_info["split_warning"] and log is not None:
            log(f"warning: {split_info['split_warning']}")
    file_sha = hashlib.sha256(Path(data).read_bytes()).hexdigest()
    training = model.metadata["training"]
    if choice:
        training["algorithm_choice"] = choice
    training.setdefault("data_sha256", data_sha256(u, y))
    training["data"] = {"path": str(data), "file_sha256": file_sha, "robot": (meta.get("robot") or {}).get("name")}
    if extra:
        training["data"]["extra"] = extra
    training["command"] = command
    size = workspace_size_m(y) or float("nan")
    return TrainRun(spec, model, errors, cal, stop, wall_s, size, str(data), file_sha, split_info)
