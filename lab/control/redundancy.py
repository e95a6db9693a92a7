"""Redundant arms: freezing some motors, and measuring how smooth a motor path is.

The six-cable arm has six motors for three tip coordinates, so a target has a whole
three-dimensional family of commands that reach it. Two tools for studying that:

* :class:`FrozenMotors` turns a forward map of ``m`` motors into one of the ``k`` free
  motors with the others held at fixed angles, and :func:`frozen_commands` the matching
  allowed set. With the three short cables frozen at 0 this is "the six-cable arm without
  its second stage", which tells which targets actually need the short cables.
* :func:`motor_path_stats` measures a motor trajectory (N, m): the largest jump between
  consecutive targets and the total travel. Without a regulariser, IK on a redundant arm
  is free to wander along the family of solutions between targets; the pull towards the
  previous command (``IKConfig(reg_weight=w)``) keeps the path short and smooth.
"""

from __future__ import annotations

import numpy as np

from lab.control.command_set import CommandSet
from lab.errors import InputError


def _check_free(free, m: int) -> np.ndarray:
    free = np.asarray(free, dtype=int)
    if free.ndim != 1 or len(free) == 0 or len(np.unique(free)) != len(free) or free.min() < 0 or free.max() >= m:
        raise InputError(f"free motors must be distinct indices in [0, {m}), got {free.tolist()}")
    return free


class FrozenMotors:
    """Forward map of the ``free`` motors (k,) of ``forward`` with the others fixed.

    This object takes (k,) or (N, k) and returns ``y`` and the (3, k) Jacobian: the
    columns of the free motors.

    Parameters
    ----------
    forward : object
        Has ``predict(u)`` for (m,) or (N, m) rad and ``predict_and_jacobian(u)`` returning
        ``y`` (3,) m and ``J`` (3, m) m/rad (e.g. :class:`lab.learn.mlp.MLP`).
    free : array_like
        Indices (k,) of the free motors, distinct, in ``[0, m)``.
    u_frozen : array_like
        Angles (m,), rad, of the frozen motors (its entries at the free indices are ignored).
    """

    def __init__(self, forward, free, u_frozen):
        self.forward = forward
        self.u_frozen = np.array(u_frozen, dtype=float)
        if self.u_frozen.ndim != 1 or not np.all(np.isfinite(self.u_frozen)):
            raise InputError(f"u_frozen must be a finite vector of motor angles, got {u_frozen!r}")
        self.free = _check_free(free, len(self.u_frozen))

    def full(self, u_free) -> np.ndarray:
        """The full command(s) for free-motor angles.

        Parameters
        ----------
        u_free : array_like
            Free-motor angles (k,) or (N, k), rad.

        Returns
        -------
        numpy.ndarray
            The full command(s) (m,) or (N, m), rad.
        """
        u_free = np.asarray(u_free, dtype=float)
        if u_free.shape[-1:] != (len(self.free),):
            raise InputError(f"expected {len(self.free)} free motor angles, got shape {u_free.shape}")
        u = np.broadcast_to(self.u_frozen, u_free.shape[:-1] + self.u_frozen.shape).copy()
        u[..., self.free] = u_free
        return u

    def predict(self, u_free) -> np.ndarray:
        """The tip(s) at free-motor angles.

        Parameters
        ----------
        u_free : array_like
            Free-motor angles (k,) or (N, k), rad.

        Returns
        -------
        numpy.ndarray
            The forward map's tip(s) (3,) or (N, 3), m.
        """
        return self.forward.predict(self.full(u_free))

    def predict_and_jacobian(self, u_free):
        """The tip and its Jacobian in the free motors.

        Parameters
        ----------
        u_free : array_like
            Free-motor angles (k,), rad.

        Returns
        -------
        y : numpy.ndarray
            The tip (3,), m.
        J : numpy.ndarray
            The Jacobian (3, k), m/rad: the free motors' columns.
        """
        y, J = self.forward.predict_and_jacobian(self.full(u_free))
        return y, np.asarray(J)[..., self.free]


def frozen_commands(commands: CommandSet, free, u_frozen) -> CommandSet:
    """The allowed set of the free motors when the others sit at fixed angles.

    ValueError if the frozen angles are themselves not allowed.

    Parameters
    ----------
    commands : CommandSet
        The allowed set of all m motors.
    free : array_like
        Indices (k,) of the free motors.
    u_frozen : array_like
        Angles (m,), rad, of the frozen motors (entries at ``free`` ignored).

    Returns
    -------
    CommandSet
        The free motors' box, and each safety row ``a.u <= b`` with the frozen motors'
        share moved to the right-hand side.
    """
    u_frozen = np.asarray(u_frozen, dtype=float)
    free = _check_free(free, commands.n)
    if u_frozen.shape != (commands.n,):
        raise InputError(f"u_frozen must have {commands.n} angles, got shape {u_frozen.shape}")
    fixed = np.setdiff1d(np.arange(commands.n), free)
    lo, hi = commands.lo[free], commands.hi[free]
    if np.any(u_frozen[fixed] < commands.lo[fixed]) or np.any(u_frozen[fixed] > commands.hi[fixed]):
        raise InputError(f"frozen angles {u_frozen[fixed].tolist()} rad are outside the motor limits")
    b = commands.b - commands.A[:, fixed] @ u_frozen[fixed]
    A = commands.A[:, free]
    if np.any(A @ lo > b + commands.tol):
        raise InputError("with these frozen angles no command of the free motors is allowed")
    return CommandSet(lo, hi, A, b)


def motor_path_stats(u_path) -> dict:
    """Smoothness of a motor trajectory.

    Parameters
    ----------
    u_path : array_like
        Commands (N, m), rad, N >= 2, finite.

    Returns
    -------
    dict
        ``max_step_rad`` (largest change of any motor between consecutive targets),
        ``mean_step_rad`` (mean over steps of the largest change), ``travel_rad`` (total
        motor travel, the sum of ``|du|`` over motors and steps) and ``max_step_index``
        (where the largest jump happens).
    """
    u = np.asarray(u_path, dtype=float)
    if u.ndim != 2 or len(u) < 2 or not np.all(np.isfinite(u)):
        raise InputError(f"u_path must be finite (N >= 2, m) motor angles, got shape {u.shape}")
    step = np.abs(np.diff(u, axis=0))
    per_step = step.max(axis=1)
    return {
        "max_step_rad": float(per_step.max()),
        "mean_step_rad": float(per_step.mean()),
        "travel_rad": float(step.sum()),
        "max_step_index": int(np.argmax(per_step)) + 1,
    }
