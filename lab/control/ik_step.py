"""One update of the paper's minimiser on its own: the projected gradient step (chapter 04).

Projected gradient descent on Eq. (1), ``O(u) = 1/2 |y(u) - y'|^2``, updates
``u+ = P_C(u - alpha J^T (y(u) - y'))`` with ``J = dy/du`` (3, m) m/rad and ``P_C`` the
Euclidean projection onto the allowed commands
(:meth:`lab.control.command_set.CommandSet.project`; on a box it is clipping, the paper's
``clip(u - alpha J^T (y - y'), u_min, u_max)``). :func:`projected_gradient_step` is that
step with a given ``alpha``, for the course's exercise and for tests: the trial step that
:meth:`lab.control.ik.IKSolver.solve` with method ``"gd"`` takes at every iteration (its
Armijo rule picks ``alpha``); the solver does not call it.
"""

from __future__ import annotations

import numpy as np

from lab.control.command_set import CommandSet
from lab.control.ik_result import check_targets
from lab.errors import InputError

__all__ = ["projected_gradient_step"]


def projected_gradient_step(forward, u_motor, target_W, step: float, commands: CommandSet) -> np.ndarray:
    """One projected gradient-descent step of Eq. (1) from ``u_motor`` (m,) rad towards the
    tip target ``target_W`` (3,) m, frame W.

    Parameters
    ----------
    forward : object
        Anything with ``predict_and_jacobian(u) -> (y (3,) m, J (3, m) m/rad)`` (the
        learned network, or :class:`lab.control.soft_ik.FEMForwardMap`).
    u_motor : array_like
        The current command (m,), rad, finite.
    target_W : array_like
        The tip target (3,), m, frame W.
    step : float
        The step length ``alpha`` (rad^2/m^2; the gradient is in m^2/rad), >= 0.
    commands : CommandSet
        The allowed set ``C`` (a box ``CommandSet(lo, hi)`` gives the paper's clip).

    Returns
    -------
    numpy.ndarray
        ``P_C(u - alpha J^T (y(u) - y'))`` (m,), rad.
    """
    u = np.asarray(u_motor, dtype=float)
    if u.shape != (commands.n,) or not np.all(np.isfinite(u)):
        raise InputError(f"u_motor must be {commands.n} finite angles in rad, got {u_motor!r}")
    if not (np.isfinite(step) and step >= 0):
        raise InputError(f"step must be finite and >= 0 (rad^2/m^2), got {step}")
    target = check_targets(target_W)
    if target.ndim != 1:
        raise InputError(f"one target (3,) m, got shape {target.shape}")
    y, J = forward.predict_and_jacobian(u)
    g = np.asarray(J, dtype=float).T @ (np.asarray(y, dtype=float) - target)  # dO/du, m^2/rad
    return commands.project(u - float(step) * g, x0=commands.project(u))
