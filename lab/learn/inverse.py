"""The direct inverse model ``u = g(y)``: the approach the paper argues against.

Instead of learning the forward map y(u) and inverting it by optimisation, one can regress
the command on the tip directly (the paper's Section I). On a **redundant** robot the data
hold many valid u for one y, and least-squares regression returns their **average**, which
need not reach y; on an invertible map the direct inverse works.

:func:`fit_inverse` trains a :class:`lab.learn.MLP` from tips (m) to commands (rad) with the
lab's trainer (:func:`lab.learn.train`); :class:`InverseModel` gives ``command(y)``, clipped to
the box of commands seen in training, and has no forward map (no ``predict``, no Jacobian).
:func:`inverse_tip_errors` measures the averaging failure: the distance of ``forward(g(y))``
from ``y``, judged by a forward model or the robot (any callable). File: ``.npz`` (no pickle)
with the network under ``net.``, the box ``u_lo, u_hi`` and a ``metadata`` JSON of
``kind: "lab.inverse_mlp"``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from lab.errors import InputError
from lab.files import atomic_open, json_default
from lab.learn.mlp import ACTIVATIONS, MLP
from lab.learn.model_io import FORMAT_VERSION, ModelFileError, _need, _read_arrays, file_metadata, model_arrays

__all__ = ["INVERSE_KIND", "InverseModel", "fit_inverse", "inverse_tip_errors", "load_inverse"]

INVERSE_KIND = "lab.inverse_mlp"


class InverseModel:
    """A network ``net`` from tip y (n_y,) m to command u (n_u,) rad, and the command box
    ``u_lo, u_hi`` (n_u,) rad of its training data. ``n_u`` and ``n_y`` are the robot's
    (motors, tip coordinates), i.e. the network's outputs and inputs.

    Parameters
    ----------
    net : MLP
        The network y (m) -> u (rad).
    u_lo, u_hi : array_like
        The command box of the training data, shape (n_u,), rad.
    metadata : dict, optional
        The training record, saved with the file.
    """

    kind = INVERSE_KIND
    has_jacobian = False  # of the forward map, which this model does not have

    def __init__(self, net: MLP, u_lo, u_hi, metadata: dict | None = None):
        self.net = net
        self.u_lo, self.u_hi = np.array(u_lo, float), np.array(u_hi, float)
        if self.u_lo.shape != (net.n_y,) or self.u_hi.shape != (net.n_y,) or np.any(self.u_hi < self.u_lo):
            raise InputError(f"the command box must be two ({net.n_y},) arrays with u_lo <= u_hi")
        self.metadata = dict(metadata or {})

    n_u = property(lambda self: self.net.n_y)
    n_y = property(lambda self: self.net.n_u)

    def __repr__(self) -> str:
        return f"InverseModel(tip {self.n_y} -> {self.n_u} motors, {self.net!r})"

    def command(self, y_target) -> np.ndarray:
        """u_motor (n_u,) rad for one tip target y (n_y,) m, or (N, n_u) for (N, n_y);
        clipped to the training data's command box (the network extrapolates outside it).

        Parameters
        ----------
        y_target : array_like
            Tip targets, shape (n_y,) or (N, n_y), m.

        Returns
        -------
        numpy.ndarray
            Commands, shape (n_u,) or (N, n_u), rad.
        """
        y = np.asarray(y_target, float)
        if y.shape[-1:] != (self.n_y,) or y.ndim not in (1, 2):
            raise InputError(f"expected tip targets of shape ({self.n_y},) or (N, {self.n_y}), got {y.shape}")
        return np.clip(self.net.predict(y), self.u_lo, self.u_hi)

    def _no_forward(self, *_):
        """The forward map and its Jacobian, which a direct inverse does not have: always raises.

        Parameters
        ----------
        *_ : object
            Ignored (the arguments of ``predict``, ``predict_and_jacobian`` or ``jacobian``).

        Returns
        -------
        NoReturn
            Never returns.

        Raises
        ------
        InputError
            Always, pointing to :meth:`command` and :func:`inverse_tip_errors`.
        """
        raise InputError(
            "a direct inverse model u = g(y) has no forward map y(u) and no Jacobian: use command(y) for the "
            "commands, and a forward model (lab.learn.inverse.inverse_tip_errors) to judge them"
        )

    predict = predict_and_jacobian = jacobian = _no_forward

    def save(self, path) -> Path:
        """Write to ``path`` (.npz, atomic, no pickle); read back with :func:`load_inverse`.

        Parameters
        ----------
        path : str or Path
            The model file.

        Returns
        -------
        Path
            ``path``.
        """
        path = Path(path)
        meta = {
            **{k: v for k, v in self.metadata.items() if k not in ("format_version", "kind")},
            "format_version": FORMAT_VERSION,
            "kind": INVERSE_KIND,
        }
        arrays = {f"net.{k}": v for k, v in model_arrays(self.net).items()}
        arrays.update(
            metadata=np.array(json.dumps(meta, default=json_default, allow_nan=False)), u_lo=self.u_lo, u_hi=self.u_hi
        )
        with atomic_open(path, "wb") as fh:
            np.savez(fh, **arrays)
        return path


def fit_inverse(u, y, hidden=(20, 20), seed: int = 0, **train_kwargs) -> InverseModel:
    """Train the direct inverse on commands ``u`` (N, n_u) rad and tips ``y`` (N, n_y) m:
    a network y -> u by :func:`lab.learn.train` (``train_kwargs``: algorithm, ratios,
    epochs, options, ...; Levenberg-Marquardt with a dividerand split by default). The
    command box is the min/max of ``u``. ``metadata["training"]`` is the trainer's record
    (its errors are command errors in rad).

    Parameters
    ----------
    u : array_like
        Commands, shape (N, n_u), rad.
    y : array_like
        Tips, shape (N, n_y), m.
    hidden : tuple of int
        Hidden layer widths.
    seed : int
        Seed of the split and the initial weights.
    **train_kwargs
        Passed to :func:`lab.learn.train`.

    Returns
    -------
    InverseModel
        The trained network y -> u with the command box of ``u``.
    """
    from lab.learn.train import train

    u, y = np.asarray(u, float), np.asarray(y, float)
    if u.ndim != 2 or y.ndim != 2 or len(u) != len(y):
        raise InputError(f"expected u (N, n_u) and y (N, n_y) with the same N, got {u.shape} and {y.shape}")
    res = train(y, u, hidden, seed=seed, **train_kwargs)
    meta = {
        "model": "direct inverse MLP",
        "units": {"u": "rad", "y": "m", "input": "y (tip, m)", "output": "u (command, rad)"},
        "training": res.model.metadata.get("training", {}),
    }
    return InverseModel(res.model, u.min(axis=0), u.max(axis=0), meta)


def load_inverse(path) -> InverseModel:
    """Read a file written by :meth:`InverseModel.save`; ModelFileError names the file and problem.

    Parameters
    ----------
    path : str or Path
        The model file.

    Returns
    -------
    InverseModel
        The network, command box and metadata as saved.
    """
    from lab.learn.model_io import read_model

    path = Path(path)
    if not path.is_file():
        raise ModelFileError(f"model file not found: {path}")
    arrays = _read_arrays(path)
    meta = file_metadata(path, arrays)
    if meta.get("kind") != INVERSE_KIND:
        raise ModelFileError(f"{path}: kind {meta.get('kind')!r} is not {INVERSE_KIND!r}")
    net = MLP(**read_model(path, ACTIVATIONS, prefix="net."))
    box = [_need(arrays, k, path) for k in ("u_lo", "u_hi")]
    for key, arr in zip(("u_lo", "u_hi"), box):
        if arr.dtype.kind != "f" or not np.all(np.isfinite(arr)):
            raise ModelFileError(f"{path}: array {key!r} is not finite floating point")
    try:
        return InverseModel(net, *box, {k: v for k, v in meta.items() if k not in ("format_version", "kind")})
    except InputError as err:
        raise ModelFileError(f"{path}: {err}") from None


def inverse_tip_errors(inverse: InverseModel, forward, y_targets) -> np.ndarray:
    """Tip error (N,) m of the direct inverse: ``|forward(g(y)) - y|`` for targets
    ``y_targets`` (N, n_y) m. ``forward`` is a forward model (anything with ``predict``:
    a network, a peer, the simulator's wrapper) or a callable u (N, n_u) -> y (N, n_y).

    Parameters
    ----------
    inverse : InverseModel
        The direct inverse g.
    forward : object or callable
        The judge: a model with ``predict`` or a callable u (N, n_u) rad -> y (N, n_y) m.
    y_targets : array_like
        Tip targets, shape (N, n_y), m.

    Returns
    -------
    numpy.ndarray
        Tip errors, shape (N,), m.
    """
    y = np.asarray(y_targets, float)
    if y.ndim != 2:
        raise InputError(f"expected y_targets of shape (N, {inverse.n_y}), got {y.shape}")
    u = inverse.command(y)
    f = forward.predict if hasattr(forward, "predict") else forward
    if not callable(f):
        raise InputError("forward must be a model with predict(u) or a callable u -> y")
    y_hat = np.asarray(f(u), float)
    if y_hat.shape != y.shape:
        raise InputError(f"forward gave tips of shape {y_hat.shape} for targets {y.shape}")
    return np.linalg.norm(y_hat - y, axis=1)
