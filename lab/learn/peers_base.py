"""What the scikit-learn peer models (:mod:`lab.learn.peers`) share: shapes, scaling, files.

Every peer is a forward map u (rad) -> y (m) with the interface of :class:`lab.learn.MLP`:
``predict(u)`` takes one command (n_u,) -> (n_y,) or a batch (N, n_u) -> (N, n_y);
``predict_and_jacobian(u)`` also gives dy/du, (n_y, n_u) or (N, n_y, n_u), m/rad;
``jacobian(u)``; ``save(path)``; ``n_u``, ``n_y``, ``kind``, ``has_jacobian`` and a
``metadata`` dict (fit time, hyperparameters, units). Inputs are scaled as ``mapminmax``
scales the network's (:func:`lab.learn.mlp.minmax_gain`): ``x = (u - u_min) g_u - 1`` in
[-1, 1] over the training data, gain 1 for a constant column; ``dx/du = diag(g_u)``.

Files are ``.npz`` (no pickle) with a JSON ``metadata`` string holding ``format_version``
and ``kind`` (``lab.gpr``, ``lab.knn``, ``lab.sklearn_mlp``), written atomically;
:func:`peer_arrays` reads one back and checks its kind, :func:`float_array` each array,
raising :class:`ModelFileError` naming the file and the problem.
"""

from __future__ import annotations

import datetime as _dt
import json
from pathlib import Path

import numpy as np

from lab.errors import InputError
from lab.files import atomic_open, json_default
from lab.learn.mlp import minmax_gain
from lab.learn.model_io import FORMAT_VERSION, ModelFileError, _need, _read_arrays, file_metadata

UNITS = {"u": "rad", "y": "m", "jacobian": "m/rad"}


def check_data(u, y, need: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """u (N, n_u) and y (N, n_y) as float arrays, N >= ``need``, all finite; else InputError."""
    u, y = np.asarray(u, float), np.asarray(y, float)
    if u.ndim != 2 or y.ndim != 2 or len(u) != len(y) or u.shape[1] < 1 or y.shape[1] < 1:
        raise InputError(f"expected u (N, n_u) and y (N, n_y) with the same N, got {u.shape} and {y.shape}")
    if len(u) < need:
        raise InputError(f"this model needs at least {need} samples, got {len(u)}")
    if not (np.all(np.isfinite(u)) and np.all(np.isfinite(y))):
        raise InputError("u and y must be finite (no NaN or inf)")
    return u, y


class PeerModel:
    """Base of the peer models: input scaling by ``u_min, u_max`` (n_u,) rad, shapes, saving.

    A subclass sets ``kind`` and ``has_jacobian`` and implements ``n_y``,
    ``_predict(u2)`` -> (N, n_y), ``_predict_and_jacobian(u2)`` -> (N, n_y), (N, n_y, n_u)
    and ``_arrays()`` (its arrays for the file, ``metadata`` excluded)."""

    kind = "lab.peer"
    has_jacobian = True

    def __init__(self, u_min, u_max, metadata: dict | None = None):
        self.u_min, self.u_max = np.array(u_min, float), np.array(u_max, float)
        if self.u_min.ndim != 1 or self.u_max.shape != self.u_min.shape:
            raise InputError(f"u_min {self.u_min.shape} and u_max {self.u_max.shape} must be equal 1-D shapes")
        self.u_gain = minmax_gain(self.u_min, self.u_max)
        self.metadata = dict(metadata or {})

    @property
    def n_u(self) -> int:
        return len(self.u_min)

    @property
    def n_y(self) -> int:
        raise NotImplementedError

    def scale(self, u2: np.ndarray) -> np.ndarray:
        """Scaled inputs x = (u - u_min) g_u - 1, (N, n_u)."""
        return (u2 - self.u_min) * self.u_gain - 1.0

    def _as_batch(self, u) -> tuple[np.ndarray, bool]:
        u = np.asarray(u, dtype=float)
        single = u.ndim == 1
        u2 = u[None, :] if single else u
        if u2.ndim != 2 or u2.shape[1] != self.n_u:
            raise InputError(f"expected u of shape (N, {self.n_u}) or ({self.n_u},), got {u.shape}")
        return u2, single

    def predict(self, u) -> np.ndarray:
        """y (N, n_y) m for u (N, n_u) rad; a single u (n_u,) gives y (n_y,)."""
        u2, single = self._as_batch(u)
        y = self._predict(u2)
        return y[0] if single else y

    def predict_and_jacobian(self, u) -> tuple[np.ndarray, np.ndarray]:
        """y (N, n_y) m and dy/du (N, n_y, n_u) m/rad; a single u (n_u,) gives (n_y,), (n_y, n_u)."""
        u2, single = self._as_batch(u)
        y, J = self._predict_and_jacobian(u2)
        return (y[0], J[0]) if single else (y, J)

    def jacobian(self, u) -> np.ndarray:
        """dy/du (N, n_y, n_u) m/rad, or (n_y, n_u) for a single u (n_u,)."""
        return self.predict_and_jacobian(u)[1]

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.n_u} -> {self.n_y}, kind {self.kind!r})"

    def save(self, path) -> Path:
        """Write the model to ``path`` (.npz, atomic, no pickle); read it back with
        :func:`lab.learn.peers.load_peer`. Returns the path."""
        from lab.files import code_version

        path = Path(path)
        meta = {
            **{k: v for k, v in self.metadata.items() if k not in ("format_version", "kind")},
            "format_version": FORMAT_VERSION,
            "kind": self.kind,
            "code_version": code_version(),
            "created": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        }
        arrays = {"metadata": np.array(json.dumps(meta, default=json_default, allow_nan=False))}
        arrays.update(u_min=self.u_min, u_max=self.u_max, **self._arrays())
        with atomic_open(path, "wb") as fh:
            np.savez(fh, **arrays)
        return path


def peer_arrays(path, kind: str) -> tuple[dict, dict, Path]:
    """(arrays, metadata without format_version/kind, path) of a peer file of ``kind``;
    ModelFileError for a missing file, a corrupt archive or another kind."""
    path = Path(path)
    if not path.is_file():
        raise ModelFileError(f"model file not found: {path}")
    arrays = _read_arrays(path)
    meta = file_metadata(path, arrays)
    if meta.get("kind") != kind:
        raise ModelFileError(f"{path}: kind {meta.get('kind')!r} is not {kind!r}")
    return arrays, {k: v for k, v in meta.items() if k not in ("format_version", "kind")}, path


def float_array(arrays: dict, key: str, path: Path, shape: tuple | None = None) -> np.ndarray:
    """Array ``key`` of a model file, checked finite floating point and (where given) of
    ``shape`` (None entries match any length); ModelFileError naming the file otherwise."""
    arr = _need(arrays, key, path)
    if arr.dtype.kind != "f" or not np.all(np.isfinite(arr)):
        raise ModelFileError(f"{path}: array {key!r} is not finite floating point")
    if shape is not None and (
        arr.ndim != len(shape) or any(s is not None and a != s for a, s in zip(arr.shape, shape))
    ):
        want = "(" + ", ".join("N" if s is None else str(s) for s in shape) + ")"
        raise ModelFileError(f"{path}: array {key!r} has shape {arr.shape}, expected {want}")
    return arr


def input_range(arrays: dict, path: Path) -> tuple[np.ndarray, np.ndarray]:
    """The ``u_min, u_max`` arrays (n_u,) of a peer file, checked."""
    u_min = float_array(arrays, "u_min", path, (None,))
    return u_min, float_array(arrays, "u_max", path, u_min.shape)
