"""A model's predicted spread in the IK: a penalty on it, and a flag where it is large.

A forward model may say how sure it is (duck-typed, e.g. a deep ensemble): by
``predict_with_std(u) -> (mean (3,) m, std (3,) m)`` and by ``members``, K >= 2 forward
maps with ``predict_and_jacobian`` and a batched ``predict``. The IK can add ``s/2 S(u)``,
``S`` the members' spread (m^2), to its objective as least-squares rows
(:func:`spread_rows`; ``spread_weight`` ``s``, dimensionless), and flags an answer
``uncertain`` when :func:`predicted_spread_m` exceeds ``max_spread_m`` (default
:data:`DEFAULT_MAX_SPREAD_M` for a model with a spread). Derivation: docs/design/ik.md.
"""

from __future__ import annotations

import numpy as np

from lab.errors import InputError

#: Spread (m) above which a target is flagged ``uncertain`` when the caller gives no
#: threshold and the model has a spread: 1 mm, about the model error of a default-trained
#: net on 1,000 samples, and twice the 0.05 cm sim/sim tracking goal.
DEFAULT_MAX_SPREAD_M = 1e-3


def members_of(model) -> list | None:
    """The ensemble members of ``model`` (a list of K >= 2 forward maps), or None."""
    members = getattr(model, "members", None)
    if members is None:
        return None
    members = list(members)
    return members if len(members) >= 2 else None


def has_spread(model) -> bool:
    """Whether a model predicts a spread.

    Parameters
    ----------
    model : object
        A forward model.

    Returns
    -------
    bool
        True if it has ``predict_with_std`` or at least two ensemble ``members``.
    """
    return callable(getattr(model, "predict_with_std", None)) or members_of(model) is not None


def predicted_spread_m(model, u_motor) -> float:
    """Predicted spread ``|std|`` of a model at a command.

    Parameters
    ----------
    model : object
        A forward model with ``predict_with_std`` or ensemble ``members``.
    u_motor : array_like
        The command (m,), rad.

    Returns
    -------
    float
        The spread (m); NaN without a spread.
    """
    u = np.asarray(u_motor, dtype=float)
    if callable(getattr(model, "predict_with_std", None)):
        _, std = model.predict_with_std(u)
        return float(np.linalg.norm(np.asarray(std, dtype=float)))
    members = members_of(model)
    if members is None:
        return float("nan")
    y = np.array([np.asarray(m.predict(u), dtype=float).reshape(-1) for m in members])
    return float(np.sqrt(np.sum((y - y.mean(axis=0)) ** 2) / len(members)))


def spread_rows(model, u_motor, weight: float) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares rows of the penalty ``weight/2 S(u)`` (module docstring) and their Jacobian.

    InputError if the model has no ensemble ``members``.

    Parameters
    ----------
    model : object
        An ensemble with K ``members``, each with ``predict_and_jacobian``.
    u_motor : array_like
        The command (m,), rad.
    weight : float
        The penalty's weight (dimensionless).

    Returns
    -------
    r_s : numpy.ndarray
        Rows (3K,), m.
    J_s : numpy.ndarray
        Their Jacobian (3K, m), m/rad.
    """
    members = members_of(model)
    if members is None:
        raise InputError("a spread penalty needs a model with ensemble members (e.g. a deep ensemble)")
    out = [m.predict_and_jacobian(np.asarray(u_motor, dtype=float)) for m in members]
    y = np.array([np.asarray(o[0], dtype=float) for o in out])  # (K, 3)
    J = np.array([np.asarray(o[1], dtype=float) for o in out])  # (K, 3, m)
    c = np.sqrt(weight / len(members))
    return (c * (y - y.mean(axis=0))).ravel(), (c * (J - J.mean(axis=0))).reshape(-1, J.shape[-1])


def spread_penalty_batch(model, u_batch, weight: float) -> np.ndarray:
    """``weight/2 S(u)`` (N,) m^2 for commands (N, m) rad, from the members' batched
    ``predict`` (no Jacobians: for the derivative-free IK)."""
    members = members_of(model)
    if members is None:
        raise InputError("a spread penalty needs a model with ensemble members (e.g. a deep ensemble)")
    u = np.atleast_2d(np.asarray(u_batch, dtype=float))
    y = np.array([np.asarray(m.predict(u), dtype=float).reshape(len(u), -1) for m in members])  # (K, N, 3M)
    return 0.5 * weight * np.sum((y - y.mean(axis=0)) ** 2, axis=(0, 2)) / len(members)
