"""The IK's two gradient methods: bounded Levenberg-Marquardt and projected gradient descent.

:func:`lm_solve` and :func:`gd_solve` minimise :class:`lab.control.ik_objective.Objective`
over the allowed commands from an allowed start, every iterate inside the set, and stop by
the shared rules of :mod:`lab.control.ik_objective`. Step rules, the Armijo constant and
the damping are explained in docs/design/ik.md. :class:`lab.control.ik.IKSolver` calls
them; they read only their arguments.
"""

from __future__ import annotations

import math

import numpy as np

from lab.control.command_set import CommandSet
from lab.control.ik_config import IKConfig
from lab.control.ik_objective import Objective, conclude, is_stationary, record
from lab.control.ik_result import IKResult

__all__ = ["ARMIJO", "lm_solve", "gd_solve"]

#: Sufficient-decrease constant of gradient descent's Armijo test (docs/design/ik.md).
ARMIJO = 0.5


def lm_solve(forward, commands: CommandSet, config: IKConfig, target, u, u_ref, reg_weight: float) -> IKResult:
    """Bounded Levenberg-Marquardt for ``target`` (3,) m from the allowed ``u`` (m,) rad,
    regularised towards ``u_ref`` (m,) rad with ``reg_weight`` (m^2/rad^2); ``config``: the
    solver's settings (its ``method`` and ``max_iter`` filled in)."""
    f = Objective(forward, target, u_ref, reg_weight, config.spread_weight)
    y, obj, rows = f.first(u)
    w, n_eval, nu, mu, eye = reg_weight, 1, 2.0, None, np.eye(len(u))
    status, history = "max_iter", []
    record(config, history, y, target)
    for it in range(config.max_iter):  # noqa: B007 (it is the iteration count after the loop)
        e = y - target
        if config.spread_weight == 0 and math.sqrt(e @ e) <= config.tol_m:
            status = "converged"
            break
        g, J_r = f.gradient(u, rows), rows[1]
        JtJ = J_r.T @ J_r + w * eye if w else J_r.T @ J_r
        lip = float((J_r * J_r).sum()) + w
        if is_stationary(commands, config.tol_stationary, u, g, lip, obj):
            status = "stationary"
            break
        if mu is None:
            mu = 1e-3 * float(np.max(np.diag(JtJ)))
        H = JtJ + mu * eye
        try:
            d = -np.linalg.solve(H, g)
            if not commands.contains(u + d, 0.0):
                d = commands.solve_qp(H, g - H @ u, x0=u) - u
        except np.linalg.LinAlgError:
            # a redundant arm's J^T J has rank 3: after many good steps mu can fall below
            # rounding against it and H is singular. Damp more, as after a rejected step.
            mu = max(mu * nu, 1e-12 * lip)
            nu *= 2.0
            continue
        predicted = -(g @ d + 0.5 * d @ JtJ @ d)
        if predicted <= 1e-30 or abs(d).max() <= 1e-15 * commands.scale:
            status = "stalled"
            break
        u_new = u + d
        y_new, obj_new, rows_new = f.evaluate(u_new)
        n_eval += 1
        rho = (obj - obj_new) / predicted
        if rho > 0:  # accept: Nielsen's update
            u, y, obj, rows = u_new, y_new, obj_new, rows_new
            mu *= max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3)
            nu = 2.0
            record(config, history, y, target)
        else:
            mu *= nu
            nu *= 2.0
            if mu > 1e20 * lip:
                status = "stalled"
                break
    else:
        it = config.max_iter
    return conclude(config, u, y, obj, target, status, it, n_eval, history)


def gd_solve(forward, commands: CommandSet, config: IKConfig, target, u, u_ref, reg_weight: float) -> IKResult:
    """Projected gradient descent with Armijo backtracking along the projection arc; the
    arguments as :func:`lm_solve`."""
    f = Objective(forward, target, u_ref, reg_weight, config.spread_weight)
    y, obj, rows = f.first(u)
    n_eval, alpha, status, history = 1, None, "max_iter", []
    record(config, history, y, target)
    for it in range(config.max_iter):  # noqa: B007 (it is the iteration count after the loop)
        if config.spread_weight == 0 and np.linalg.norm(y - target) <= config.tol_m:
            status = "converged"
            break
        g = f.gradient(u, rows)
        lip = float(np.sum(rows[1] ** 2)) + reg_weight
        if is_stationary(commands, config.tol_stationary, u, g, lip, obj):
            status = "stationary"
            break
        a = 1.0 / lip if alpha is None else 2.0 * alpha
        for _ in range(60):  # Armijo along the projection arc
            u_new = commands.project(u - a * g, x0=u)
            y_new, obj_new, rows_new = f.evaluate(u_new)
            n_eval += 1
            if obj_new <= obj + ARMIJO * float(g @ (u_new - u)):
                break
            a *= 0.5
        else:
            status = "stalled"
            break
        if np.array_equal(u_new, u):
            status = "stalled"
            break
        u, y, obj, rows, alpha = u_new, y_new, obj_new, rows_new, a
        record(config, history, y, target)
    else:
        it = config.max_iter
    return conclude(config, u, y, obj, target, status, it, n_eval, history)
