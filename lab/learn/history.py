"""History models: a forward model of the current command *and* the K commands before it.

A soft robot's tip depends on where it came from (friction, hysteresis, creep), not only
on the command now. A history model learns y_t = f(u_t, u_{t-1}, ..., u_{t-K}) from
measured sequences: :func:`history_features` builds its inputs, (N, m (K+1)), one row per
measurement, the past taken within the row's sequence (:mod:`lab.data.sequences`; at a
sequence start the missing past is the sequence's first command repeated). The model file
records ``"history": {"k": K, "n_motors": m}`` in its metadata (:func:`history_of` reads it).

The IK moves the current command only: :func:`with_past` fixes the past and gives a model
over u_t (n_u = m) with the exact Jacobian dy/du_t -- the first m columns of the base
model's -- and the base's spread (ensemble members, ``predict_with_std``) with the past
fixed; :func:`at_rest` is the robot resting at a command, u -> f(u, u, ..., u), whose
Jacobian is the sum of the K+1 blocks. :func:`data_bounds` reads the per-motor box of the
commands a model was trained on (``metadata["data_bounds"]``, written by
:func:`record_data_bounds` for every model ``train`` fits), for an IK that must stay
where the model has seen data.
"""

from __future__ import annotations

import numpy as np

from lab.errors import InputError

__all__ = [
    "MAX_HISTORY",
    "at_rest",
    "check_history_fits",
    "data_bounds",
    "history_features",
    "history_of",
    "past_commands",
    "record_data_bounds",
    "record_history",
    "with_past",
]

#: Most past commands a history model may take (``--history K``): inputs grow as m (K+1).
MAX_HISTORY = 10


def _check_k(k) -> int:
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 0 <= int(k) <= MAX_HISTORY:
        raise InputError(f"history K must be an integer from 0 to {MAX_HISTORY}, got {k!r}")
    return int(k)


def history_features(u, seq_ids, k: int) -> np.ndarray:
    """Inputs of a history model: (N, m (k+1)) with columns [u_t, u_{t-1}, ..., u_{t-k}].

    ``u`` (N, m) commands in measurement order; ``seq_ids`` (N,) the sequence of each row
    (a sequence is a run of equal consecutive ids, e.g. :func:`lab.data.sequences.sequence_ids`).
    Before a sequence's first row, the past is that first command repeated.

    Parameters
    ----------
    u : array_like
        Commands in measurement order, shape (N, m), rad.
    seq_ids : array_like
        The sequence of each row, shape (N,).
    k : int
        Past commands, 0 to :data:`MAX_HISTORY`.

    Returns
    -------
    numpy.ndarray
        Shape (N, m (k+1)), rad.
    """
    u = np.asarray(u, dtype=float)
    ids = np.asarray(seq_ids)
    k = _check_k(k)
    if u.ndim != 2 or ids.shape != (len(u),):
        raise InputError(f"history features need u (N, m) and sequence ids (N,), got {u.shape} and {ids.shape}")
    n = len(u)
    rows = np.arange(n)
    start = np.zeros(n, dtype=int)
    if n:
        new = np.r_[True, ids[1:] != ids[:-1]]
        start = np.maximum.accumulate(np.where(new, rows, 0))
    return np.hstack([u[np.maximum(rows - j, start)] for j in range(k + 1)])


def check_history_fits(spec, k: int, seq_ids, data) -> None:
    """Refuse a history K that is not below the longest measurement sequence of the data
    (every row's past would then reach back past its sequence's first row): the one rule
    ``train``, ``splits`` and ``compare`` share, as a :meth:`lab.specs.Spec.field_error`
    of ``spec``'s ``history`` field.

    Parameters
    ----------
    spec : lab.specs.Spec
        The spec whose ``history`` field holds K (a TrainSpec, a CompareSpec).
    k : int
        The history K asked for (the largest one, for several).
    seq_ids : array_like, shape (N,)
        The sequence of each row (:func:`lab.data.sequences.sequence_ids`).
    data : str or Path
        The dataset, named in the message.
    """
    ids = np.asarray(seq_ids)
    runs = np.diff(np.flatnonzero(np.r_[True, ids[1:] != ids[:-1], True])) if len(ids) else np.zeros(1, int)
    if k and k >= runs.max():
        raise spec.field_error(
            f"{spec.name_of('history')} {k}: the longest measurement sequence of {data} has {runs.max()} rows "
            f"({len(runs)} sequence(s), sidecar key sequence_starts); K must be below it",
            "history",
        )


def record_history(model, k: int, n_motors: int) -> None:
    """Write ``"history": {"k", "n_motors"}`` into ``model.metadata`` (checked against n_u)."""
    k = _check_k(k)
    if n_motors * (k + 1) != model.n_u:
        raise InputError(f"a history-{k} model of {n_motors} motors takes {n_motors * (k + 1)} inputs, not {model.n_u}")
    model.metadata["history"] = {"k": k, "n_motors": int(n_motors)}


def _history(model) -> tuple[int, int]:
    """(K, m) of ``model``: (0, n_u) without ``metadata["history"]``; InputError if malformed."""
    h = (getattr(model, "metadata", None) or {}).get("history")
    n_u = int(model.n_u)
    if h is None:
        return 0, n_u
    k, m = (h.get(key) if isinstance(h, dict) else None for key in ("k", "n_motors"))
    ok = all(isinstance(v, int) and not isinstance(v, bool) for v in (k, m))
    if not ok or not 0 <= k <= MAX_HISTORY or m < 1 or m * (k + 1) != n_u:
        raise InputError(
            f"model metadata 'history' must be {{'k': 0..{MAX_HISTORY}, 'n_motors': m}} with m (k+1) = the "
            f"model's {n_u} inputs, got {h!r}"
        )
    return k, m


def history_of(model) -> int:
    """K, the past commands ``model`` takes (``metadata["history"]["k"]``); 0 for an ordinary model.

    Parameters
    ----------
    model : object
        A forward model with ``n_u`` and ``metadata``.

    Returns
    -------
    int
        K, 0 to :data:`MAX_HISTORY`.
    """
    return _history(model)[0]


def past_commands(u_before, k: int) -> np.ndarray:
    """The past (k, m), newest first, of the next command after ``u_before`` (T, m), oldest
    first, T >= 1; fewer than k rows are padded with the first (the sequence-start rule)."""
    u_before = np.asarray(u_before, dtype=float)
    k = _check_k(k)
    if u_before.ndim != 2 or len(u_before) < 1:
        raise InputError(f"u_before must be (T, m) with T >= 1, got {u_before.shape}")
    idx = np.maximum(len(u_before) - 1 - np.arange(k), 0)
    return u_before[idx]


class _InputMap:
    """``base`` seen through a map of the current command u (m,) to its input x (m (k+1),):
    ``"past"`` x = [u, past], ``"rest"`` x = [u, u, ..., u]. dy/du is dy/dx's first block or
    the sum of its blocks, exact."""

    def __init__(self, base, mode: str, k: int, m: int, past: np.ndarray | None = None):
        self.base, self.mode, self.k, self.n_u = base, mode, k, m
        self._past = past.reshape(-1) if past is not None else np.zeros(0)
        self.n_y = int(base.n_y)
        self.has_jacobian = bool(getattr(base, "has_jacobian", True))
        self.kind = getattr(base, "kind", None)
        # an ordinary model over u_t: history_of(view) is 0, data_bounds(view) the base's
        self.metadata = {k: v for k, v in (getattr(base, "metadata", None) or {}).items() if k != "history"}

    def __repr__(self) -> str:
        what = "past fixed" if self.mode == "past" else "at rest"
        return f"{type(self).__name__}({self.base!r}, history {self.k}, {what})"

    def inputs(self, u) -> tuple[np.ndarray, bool]:
        """The base model's inputs (N, m (k+1)) for u (N, m) or (m,); and whether u was one."""
        u = np.asarray(u, dtype=float)
        single = u.ndim == 1
        u2 = u[None, :] if single else u
        if u2.ndim != 2 or u2.shape[1] != self.n_u:
            raise InputError(f"expected u of shape (N, {self.n_u}) or ({self.n_u},), got {u.shape}")
        if self.mode == "rest":
            return np.tile(u2, (1, self.k + 1)), single
        return np.hstack([u2, np.broadcast_to(self._past, (len(u2), len(self._past)))]), single

    def _du(self, J: np.ndarray) -> np.ndarray:
        """d/du from d/dx (..., n_x): the first m columns, or the sum of the k+1 blocks."""
        if self.mode == "past":
            return np.ascontiguousarray(J[..., : self.n_u])
        return J.reshape(*J.shape[:-1], self.k + 1, self.n_u).sum(axis=-2)

    def _out(self, values, single):
        return tuple(v[0] for v in values) if single else tuple(values)

    def predict(self, u) -> np.ndarray:
        """y (N, n_y) for u (N, m); (n_y,) for one u (m,)."""
        x, single = self.inputs(u)
        y = np.asarray(self.base.predict(x))
        return y[0] if single else y

    def predict_and_jacobian(self, u) -> tuple[np.ndarray, np.ndarray]:
        """y (N, n_y) and dy/du (N, n_y, m), the current command's; (n_y,), (n_y, m) for one u."""
        x, single = self.inputs(u)
        y, J = self.base.predict_and_jacobian(x)
        return self._out((np.asarray(y), self._du(np.asarray(J))), single)

    def jacobian(self, u) -> np.ndarray:
        """dy/du (N, n_y, m), or (n_y, m) for one u."""
        return self.predict_and_jacobian(u)[1]

    # The spread, only where the base has one (lab.control.spread looks these up by name).
    def _need(self, name: str):
        if not callable(getattr(self.base, name, None)):
            raise AttributeError(f"{type(self.base).__name__} has no {name}")

    @property
    def predict_with_std(self):
        """(mean, std), (N, n_y) m each, of the base with the past fixed (base's keywords)."""
        self._need("predict_with_std")

        def predict_with_std(u, *args, **kwargs):
            x, single = self.inputs(u)
            return self._out(self.base.predict_with_std(x, *args, **kwargs), single)

        return predict_with_std

    @property
    def std_and_jacobian(self):
        """(std (N, n_y) m, d std / du (N, n_y, m)) of the base with the past fixed."""
        self._need("std_and_jacobian")

        def std_and_jacobian(u):
            x, single = self.inputs(u)
            std, dstd = self.base.std_and_jacobian(x)
            return self._out((np.asarray(std), self._du(np.asarray(dstd))), single)

        return std_and_jacobian

    @property
    def members(self) -> list:
        """The base's ensemble members, each seen through the same map."""
        members = getattr(self.base, "members", None)
        if members is None:
            raise AttributeError(f"{type(self.base).__name__} has no members")
        past = self._past.reshape(self.k, self.n_u) if self.mode == "past" else None
        return [_InputMap(mb, self.mode, self.k, self.n_u, past) for mb in members]

    @property
    def spread_scale(self) -> float:
        return self.base.spread_scale


def with_past(model, past_u) -> _InputMap:
    """``model`` over the current command only: u (m,) -> f(u, past), the past ``past_u``
    (k, m) newest first (u_{t-1} first), k = :func:`history_of` (k = 0: an empty past).

    The result has ``n_u`` = m, ``n_y``, ``has_jacobian``, ``predict`` (u (N, m) or (m,)),
    ``predict_and_jacobian`` / ``jacobian`` (dy/du_t, exact: the base's first m columns)
    and, where the base has them, ``predict_with_std``, ``std_and_jacobian`` and
    ``members`` (each member with the same past).

    Parameters
    ----------
    model : object
        A history model (or an ordinary one, k = 0).
    past_u : array_like or None
        The past commands, shape (k, m), rad, newest first.

    Returns
    -------
    object
        The view u (m,) rad -> y, with the interface above.
    """
    k, m = _history(model)
    past = np.zeros((0, m)) if past_u is None and k == 0 else np.asarray(past_u, dtype=float)
    past = past.reshape(-1, m) if k == 0 and past.size == 0 else past
    if past.shape != (k, m) or not np.all(np.isfinite(past)):
        raise InputError(
            f"the past must be {k} finite commands of {m} motors, newest first: ({k}, {m}), got {past.shape}"
        )
    return _InputMap(model, "past", k, m, past)


def at_rest(model) -> _InputMap:
    """``model`` at rest: u (m,) -> f(u, u, ..., u), the robot held at one command; its
    Jacobian is the sum of the k+1 blocks of the base's (exact). The interface of
    :func:`with_past`. For an ordinary model (k = 0), the model itself under another name.

    Parameters
    ----------
    model : object
        A history model (or an ordinary one).

    Returns
    -------
    object
        The view u (m,) rad -> y, with the interface of :func:`with_past`.
    """
    k, m = _history(model)
    return _InputMap(model, "rest", k, m)


def record_data_bounds(model, u_motor) -> None:
    """Write ``"data_bounds": {"u_min": [m], "u_max": [m]}`` into ``model.metadata``: the
    per-motor min/max of ``u_motor`` (N, m), the commands the model was fitted to (for a
    history model, the current command's m columns)."""
    u = np.asarray(u_motor, dtype=float)
    if u.ndim != 2 or len(u) == 0 or not np.all(np.isfinite(u)):
        raise InputError(f"data bounds need finite commands (N >= 1, m), got shape {u.shape}")
    model.metadata["data_bounds"] = {"u_min": u.min(axis=0).tolist(), "u_max": u.max(axis=0).tolist()}


def data_bounds(model) -> tuple[np.ndarray, np.ndarray] | None:
    """(lo (m,), hi (m,)): the per-motor min/max of the commands ``model`` was trained on,
    units of the data's commands, from ``metadata["data_bounds"]``; None for a model saved
    without them (before they were recorded). InputError if they are malformed.

    Parameters
    ----------
    model : object
        A forward model with ``metadata``.

    Returns
    -------
    tuple of numpy.ndarray or None
        (lo, hi), each shape (m,), in the data's command units (rad for a shipped robot).
    """
    b = (getattr(model, "metadata", None) or {}).get("data_bounds")
    if b is None:
        return None
    m = _history(model)[1]
    try:
        lo, hi = (np.asarray(b[key], dtype=float) for key in ("u_min", "u_max"))
    except (KeyError, TypeError, ValueError):
        lo = hi = np.zeros(0)
    if lo.shape != (m,) or hi.shape != (m,) or not (np.all(np.isfinite(lo)) and np.all(lo <= hi)):
        raise InputError(f"model metadata 'data_bounds' must hold u_min <= u_max, {m} finite numbers each, got {b!r}")
    return lo, hi
