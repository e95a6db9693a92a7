"""Every forward (and the direct inverse) model behind one name: fit, load, ten-split study.

``MODEL_CHOICES`` are the names ``python -m lab train/splits --model`` takes: ``mlp``
(:func:`lab.learn.train.train`, LM or ``algorithm="br"``), ``ensemble``
(:func:`lab.learn.ensemble.train_ensemble`), the scikit-learn peers ``gpr``, ``knn``,
``sklearn-mlp`` (:mod:`lab.learn.peers`), and ``inverse-mlp``, the direct inverse u = g(y)
(:mod:`lab.learn.inverse`): its held-out error is the command error ``|g(y) - u|`` (rad)
and, given a forward model, the tip error ``|forward(g(y)) - y|`` (m) as ``mean_distance_m``
(NaN without one). :func:`fit_model` fits one spec of :mod:`lab.learn.model_specs` (one
frozen dataclass per kind). :func:`load_model` reads any model file by the ``kind`` in its metadata
through :data:`MODEL_KINDS`, a dict of loader functions imported here by name.
:func:`evaluate_model_splits` is the paper's ten-split study for any model, on
:func:`lab.learn.train.train`'s splits for the same seeds, so models compare split by split.
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from lab.errors import InputError
from lab.learn.ensemble import load_ensemble, train_ensemble
from lab.learn.inverse import fit_inverse, load_inverse
from lab.learn.metrics import error_report
from lab.learn.mlp import ACTIVATIONS, MLP
from lab.learn.model_io import ModelFileError, file_metadata, read_model
from lab.learn.model_specs import MODEL_SPECS, EnsembleSpec, GPRSpec, InverseSpec, KNNSpec, NetworkSpec
from lab.learn.peers import fit_gpr, fit_knn, fit_sklearn_mlp, load_peer
from lab.learn.residual import load_residual
from lab.learn.train import max_epochs, train

__all__ = [
    "MODEL_CHOICES",
    "MODEL_KINDS",
    "evaluate_model_splits",
    "fit_model",
    "held_out_errors",
    "load_model",
    "net_options",
    "outer_split",
]

#: the model kinds, ``--model``'s choices
MODEL_CHOICES = tuple(MODEL_SPECS)


def _load_mlp(path) -> MLP:
    return MLP(**read_model(path, ACTIVATIONS))


def _load_residual(path):
    return load_residual(path, MLP, ACTIVATIONS)


#: file kind -> loader function (path -> model)
MODEL_KINDS = {
    "lab.mlp": _load_mlp,
    "lab.residual": _load_residual,
    "lab.ensemble": load_ensemble,
    "lab.gpr": load_peer,
    "lab.knn": load_peer,
    "lab.sklearn_mlp": load_peer,
    "lab.inverse_mlp": load_inverse,
}


def _check_spec(spec) -> None:
    if type(spec) not in MODEL_SPECS.values():
        raise InputError(f"spec must be one of {[c.__name__ for c in MODEL_SPECS.values()]}, got {type(spec).__name__}")


def fit_model(spec, u, y, progress=None):
    """Fit the model ``spec`` describes to all of the data.

    Parameters
    ----------
    spec : NetworkSpec, EnsembleSpec, InverseSpec, GPRSpec, KNNSpec or SklearnMLPSpec
        The model kind and its settings (:mod:`lab.learn.model_specs`;
        :func:`lab.learn.model_specs.model_spec` builds one from a kind's name).
    u : array_like, shape (N, n_u)
        Commands (rad).
    y : array_like, shape (N, n_y)
        Tip positions (m).
    progress : callable, optional
        ``progress(done, total)`` in epochs, for the networks (mlp, ensemble, inverse-mlp);
        the other kinds fit in one step and do not call it.

    Returns
    -------
    MLP, Ensemble, InverseModel, GPRModel, KNNModel or SklearnMLPModel
        The fitted model. Networks (mlp, each ensemble member, inverse-mlp) are trained by
        :func:`lab.learn.train.train` on the spec's split ``ratios`` of these data.
    """
    _check_spec(spec)
    u, y = np.asarray(u, float), np.asarray(y, float)
    if isinstance(spec, NetworkSpec):
        kwargs = spec.train_kwargs()
        if isinstance(spec, EnsembleSpec):
            return train_ensemble(u, y, spec.hidden, k=spec.members, seed=spec.seed, n_jobs=spec.n_jobs,
                                  progress=progress, **kwargs)  # fmt: skip
        if progress is not None:
            limit = max_epochs(kwargs.get("algorithm", "lm"), kwargs.get("epochs"), kwargs.get("options"))
            kwargs["progress"] = lambda epoch, row: progress(epoch, limit)
        if isinstance(spec, InverseSpec):
            return fit_inverse(u, y, spec.hidden, seed=spec.seed, **kwargs)
        return train(u, y, spec.hidden, seed=spec.seed, **kwargs).model
    if isinstance(spec, GPRSpec):
        return fit_gpr(u, y, seed=spec.seed)
    if isinstance(spec, KNNSpec):
        return fit_knn(u, y, n_neighbors=spec.n_neighbors)
    return fit_sklearn_mlp(u, y, hidden=spec.hidden, seed=spec.seed)


def net_options(algorithm: str = "lm", min_grad: float | None = None):
    """Options for :func:`lab.learn.train.train` with a gradient stop.

    Parameters
    ----------
    algorithm : str
        One of ``lab.learn.train.ALGORITHMS``.
    min_grad : float, optional
        The gradient stop (None: the algorithm's default).

    Returns
    -------
    LMOptions, BROptions, LMSubsampleOptions or None
        ``LMOptions(min_grad=...)`` for "lm" and "auto", ``BROptions(min_grad=...)`` for
        "br", ``LMSubsampleOptions(min_grad=...)`` for "lm-subsample"; None otherwise (Adam
        and L-BFGS have no such stop) or without ``min_grad``.
    """
    if min_grad is None or algorithm not in ("lm", "br", "lm-subsample", "auto"):
        return None
    if min_grad < 0:
        raise InputError(f"min_grad must be >= 0, got {min_grad}")
    from lab.learn.bayes import BROptions
    from lab.learn.lm import LMOptions
    from lab.learn.lm_subsample import LMSubsampleOptions

    kind = {"br": BROptions, "lm-subsample": LMSubsampleOptions}.get(algorithm, LMOptions)
    return kind(min_grad=min_grad)


def load_model(path):
    """Any lab model file, by the ``kind`` in its metadata (:data:`MODEL_KINDS`); raises
    :class:`lab.learn.model_io.ModelFileError` naming the file and the problem, an
    unknown kind included.

    Parameters
    ----------
    path : str or Path
        The model file.

    Returns
    -------
    object
        The model: an MLP, ensemble, inverse, residual or peer model, by its kind.
    """
    kind = file_metadata(path).get("kind")
    if kind not in MODEL_KINDS:
        raise ModelFileError(f"{path}: unknown model kind {kind!r} (known: {sorted(MODEL_KINDS)})")
    return MODEL_KINDS[kind](path)


def outer_split(n: int, ratios, seed: int, groups=None):
    """The split :func:`lab.learn.train.train` draws first from ``default_rng(seed)``: the
    same train/validation/test indices for any model fitted with that seed (random, or of
    whole ``groups`` (n,) when given: :func:`lab.learn.split.divide_groups`)."""
    from lab.learn.split import divide

    return divide(n, ratios, np.random.default_rng(seed), groups)


def held_out_errors(model, u, y, forward=None) -> dict:
    """{"mse_m2", "mean_distance_m", "n"} of a forward model on (u, y) (None values for an
    empty set); for a direct inverse also ``mean_command_error_rad`` = mean |g(y) - u|, and
    its tip errors through ``forward`` (NaN without one)."""
    if getattr(model, "kind", None) != "lab.inverse_mlp":
        return error_report(model, u, y)
    if len(u) == 0:
        return {"mse_m2": None, "mean_distance_m": None, "mean_command_error_rad": None, "n": 0}
    out = {"mean_command_error_rad": float(np.mean(np.linalg.norm(model.command(y) - u, axis=1))), "n": len(u)}
    if forward is None:
        return {"mse_m2": float("nan"), "mean_distance_m": float("nan"), **out}
    from lab.learn.inverse import inverse_tip_errors

    d = inverse_tip_errors(model, forward, y)
    return {"mse_m2": float(np.mean(d * d) / y.shape[1]), "mean_distance_m": float(np.mean(d)), **out}


def _one_split(u, y, spec, ratios, seed, forward, groups=None) -> dict:
    from lab.workers import watch_parent

    watch_parent()
    name = spec.kind
    split = outer_split(len(u), ratios, seed, groups)
    t0 = time.perf_counter()
    seeded = replace(spec, seed=seed) if hasattr(spec, "seed") else spec
    model = fit_model(seeded, u[split.train], y[split.train])
    wall_s = time.perf_counter() - t0
    row = {"model": name, "seed": seed, "wall_s": wall_s}
    if hasattr(spec, "hidden"):
        row["hidden"] = "-".join(map(str, spec.hidden))
    sets = {"train": split.train, "validation": split.validation, "test": split.test}
    if name == "ensemble" and len(split.validation):  # the post-hoc spread scale
        model.fit_spread_scale(u[split.validation], y[split.validation])
    for set_name, idx in sets.items():
        err = held_out_errors(model, u[idx], y[idx], forward)
        for key, value in err.items():
            row[f"{set_name}_{key}"] = float("nan") if value is None else value
    if name in ("ensemble", "gpr") and len(split.test):
        from lab.learn.spread_calibration import calibration

        keys = ("within_1sigma", "within_2sigma", "radius_within_68")
        cal = calibration(y[split.test], *model.predict_with_std(u[split.test]))
        row.update({f"test_{k}": cal[k] for k in keys})
        if name == "ensemble":  # before the spread scale, and the scale
            raw = calibration(y[split.test], *model.predict_with_std(u[split.test], scaled=False))
            row.update({f"test_raw_{k}": raw[k] for k in keys})
            row["spread_scale"] = model.spread_scale
    return row


def evaluate_model_splits(
    u,
    y,
    spec,
    *,
    n_splits: int = 10,
    ratios=(0.9, 0.0, 0.1),
    seed: int = 0,
    n_jobs: int = 1,
    forward=None,
    groups=None,
    on_split=None,
) -> list[dict]:
    """The ten-split study for any model: fit on the training part of each of ``n_splits``
    random splits and report errors.

    Parameters
    ----------
    u : array_like, shape (N, n_u)
        Commands (rad).
    y : array_like, shape (N, n_y)
        Tip positions (m).
    spec : NetworkSpec, EnsembleSpec, InverseSpec, GPRSpec, KNNSpec or SklearnMLPSpec
        The model (:func:`lab.learn.model_specs.model_spec`); its ``seed`` is replaced by each split's.
    n_splits : int
        Number of splits (:func:`lab.learn.studies.run_seeds` seeds, :func:`outer_split` indices).
    ratios : tuple of float
        (train, validation, test) ratios of every split.
    seed : int
        Seed of the split seeds.
    n_jobs : int
        Worker processes, one split each.
    forward : forward model, optional
        Judges a direct inverse's commands by their tips (NaN without one).
    groups : array_like, shape (N,), optional
        Split whole groups (measurement sequences) instead of rows
        (:func:`lab.learn.split.divide_groups`).
    on_split : callable, optional
        ``on_split(done, n_splits)`` as splits finish, in split order.

    Returns
    -------
    list of dict
        One row per split. A :class:`NetworkSpec`'s rows are
        :func:`lab.learn.studies.evaluate_splits`' (its own training-set split). Other
        models' rows have ``model``, ``seed``, ``split``, ``wall_s`` (fit time, s) and per
        set ``{set}_n``, ``{set}_mse_m2``, ``{set}_mean_distance_m`` (NaN where empty);
        ensembles and GPs add the test calibration (``test_within_1sigma``,
        ``test_within_2sigma``, ``test_radius_within_68``,
        :func:`lab.learn.spread_calibration.calibration`; an ensemble's spread scale is fitted on the
        validation set when there is one, ``spread_scale``, and ``test_raw_*`` are the same
        before it); the inverse adds ``{set}_mean_command_error_rad``.
    """
    from lab.learn.split import check_enough_data
    from lab.learn.studies import evaluate_splits, run_jobs, run_seeds

    _check_spec(spec)
    name = spec.kind
    u, y = np.asarray(u, float), np.asarray(y, float)
    if type(spec) is NetworkSpec:
        kwargs = {
            "hidden": spec.hidden,
            "algorithm": spec.algorithm,
            "epochs": spec.epochs,
            "options": spec.options,
            "activation": spec.activation,
        }
        if groups is not None:
            kwargs["groups"] = groups
        rows = evaluate_splits(u, y, n_splits=n_splits, ratios=ratios, seed=seed, n_jobs=n_jobs, on_split=on_split,
                               **kwargs)  # fmt: skip
        return [{"model": name, **r} for r in rows]
    check_enough_data(u, ratios)
    jobs = [(u, y, spec, tuple(ratios), s, forward, groups) for s in run_seeds(seed, n_splits)]
    rows = run_jobs(_one_split, jobs, n_jobs, on_split)
    for i, row in enumerate(rows):
        row["split"] = i
    return rows
