"""Derivative-free IK: secant Levenberg-Marquardt with a compass poll, inside the allowed set.

For forward models without a useful Jacobian (``has_jacobian = False``, e.g. a k-nearest-
neighbour regressor): :func:`dfo_solve` minimises the same objective as LM/GD
(:mod:`lab.control.ik_objective`), calling only the model's batched ``predict``. Each
iteration fits a secant Jacobian over the scale of the last step, takes a bounded LM step
with it, and polls the compass directions where that step fails (docs/design/ik.md: the
method, its step scale and its stopping rules).
"""

from __future__ import annotations

import numpy as np

from lab.control.command_set import CommandSet
from lab.control.ik_config import IKConfig
from lab.control.ik_objective import conclude, is_stationary, record
from lab.control.ik_result import IKResult
from lab.control.spread import members_of
from lab.errors import InputError

__all__ = ["dfo_solve", "MIN_STEP_REL", "MAX_STEP_REL", "START_STEP_REL", "STALL_ITERATIONS", "STALL_REL"]

#: Secant step bounds, as fractions of the largest motor range.
MIN_STEP_REL = 1e-9
MAX_STEP_REL = 0.05
#: Secant step of the first iteration, as a fraction of the largest motor range.
START_STEP_REL = 0.01
#: Stop ("stationary") when ``STALL_ITERATIONS`` iterations lowered ``O`` by less than
#: ``STALL_REL`` of its value: a k-NN map has a shallow local minimum at every sample,
#: where the poll keeps finding crumbs.
STALL_ITERATIONS, STALL_REL = 10, 1e-3


def _residuals(forward, spread_weight, target, U) -> np.ndarray:
    """Residual rows (P, 3 [+ 3K]) m at commands U (P, m): tip error, then the spread rows."""
    Y = np.asarray(forward.predict(U), dtype=float).reshape(len(U), -1)
    R = Y - target
    if spread_weight > 0:
        members = members_of(forward)
        Yk = np.array([np.asarray(m.predict(U), dtype=float).reshape(len(U), -1) for m in members])
        S = np.sqrt(spread_weight / len(members)) * (Yk - Yk.mean(axis=0))  # (K, P, 3)
        R = np.hstack([R, S.transpose(1, 0, 2).reshape(len(U), -1)])
    return R


def _objective(reg_weight, R, U, u_ref) -> np.ndarray:
    obj = 0.5 * np.sum(R * R, axis=1) + 0.5 * reg_weight * np.sum((U - u_ref) ** 2, axis=1)
    return np.where(np.all(np.isfinite(R), axis=1), obj, np.inf)


def _secant_points(commands, u, h) -> np.ndarray:
    """Allowed points (m, m) at distance about h from u along each motor."""
    pts = []
    for i in range(commands.n):
        e = np.zeros(commands.n)
        e[i] = h
        pts.append(u + e if commands.contains(u + e) else commands.project(u - e, x0=u))
    return np.array(pts)


def dfo_solve(forward, commands: CommandSet, config: IKConfig, target, u, u_ref, reg_weight: float) -> IKResult:
    """Derivative-free solve for one target through a forward map's batched ``predict``.

    Parameters
    ----------
    forward : object
        The forward map: ``predict(U (P, m) rad) -> (P, 3) m``; its ensemble members when
        ``config.spread_weight > 0``.
    commands : CommandSet
        The allowed commands.
    config : IKConfig
        The solver's settings (``max_iter`` filled in).
    target : numpy.ndarray
        The target (3,) of the tip, or (3M,) of the M markers driven, m, frame W.
    u : numpy.ndarray
        The allowed start (m,), rad.
    u_ref : numpy.ndarray
        The command (m,), rad, the regularisation pulls toward.
    reg_weight : float
        Weight of that pull (m^2/rad^2).

    Returns
    -------
    IKResult
        The solution; its ``time_s`` is filled in by :meth:`lab.control.ik.IKSolver.solve`.
    """
    cs, w, s_w = commands, reg_weight, config.spread_weight
    n_t = len(target)  # 3 per marker driven
    R0 = _residuals(forward, s_w, target, u[None])
    r, obj = R0[0], float(_objective(w, R0, u[None], u_ref)[0])
    if not np.isfinite(obj):
        raise InputError(f"the forward map gives no finite tip at the start command {u.tolist()} rad")
    h, h_min, h_max = START_STEP_REL * cs.scale, MIN_STEP_REL * cs.scale, MAX_STEP_REL * cs.scale
    n_eval, mu, nu, eye, status, history = 1, None, 2.0, np.eye(cs.n), "max_iter", []
    objs_seen = [obj]
    record(config, history, r[:n_t] + target, target)
    for it in range(config.max_iter):  # noqa: B007 (it is the iteration count after the loop)
        if s_w == 0 and np.linalg.norm(r[:n_t]) <= config.tol_m:
            status = "converged"
            break
        stalled = len(objs_seen) > STALL_ITERATIONS and (
            objs_seen[-STALL_ITERATIONS - 1] - obj < STALL_REL * objs_seen[-STALL_ITERATIONS - 1]
        )
        if h < h_min or stalled:
            status = "stationary"
            break
        P = _secant_points(cs, u, h)
        RP = _residuals(forward, s_w, target, P)
        n_eval += len(P)
        J = np.linalg.lstsq(P - u, RP - r, rcond=None)[0].T  # (n_r, m): d r / d u over scale h
        g = J.T @ r + w * (u - u_ref)
        JtJ = J.T @ J + w * eye
        lip = float(np.sum(J * J)) + w
        if np.all(np.isfinite(J)) and is_stationary(cs, config.tol_stationary, u, g, lip, obj):
            status = "stationary"
            break
        if mu is None:
            mu = 1e-3 * max(float(np.max(np.diag(JtJ))), 1e-300)
        H = JtJ + mu * eye
        d = -np.linalg.solve(H, g)
        if not cs.contains(u + d, 0.0):
            d = cs.solve_qp(H, g - H @ u, x0=u) - u
        predicted = -(g @ d + 0.5 * d @ JtJ @ d)
        trials = [u + d] if predicted > 0 and np.max(np.abs(d)) > 0 else []
        moved = False
        if trials:
            R1 = _residuals(forward, s_w, target, np.array(trials))
            n_eval += 1
            obj1 = float(_objective(w, R1, np.array(trials), u_ref)[0])
            rho = (obj - obj1) / predicted
            if rho > 0:  # accept: Nielsen's update, and the secant scale follows the step
                u, r, obj, moved = u + d, R1[0], obj1, True
                mu *= max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3)
                nu, h = 2.0, float(np.clip(np.max(np.abs(d)), h_min, h_max))
        if not moved:
            mu, nu = mu * nu, nu * 2.0
            poll = np.array([cs.project(u + s * h * e, x0=u) for e in eye for s in (1.0, -1.0)])
            RP = _residuals(forward, s_w, target, poll)
            n_eval += len(poll)
            objs = _objective(w, RP, poll, u_ref)
            best = int(np.argmin(objs))
            if objs[best] < obj:  # the secant model was wrong at this scale: a fresh damping
                u, r, obj, mu, nu = poll[best], RP[best], float(objs[best]), None, 2.0
            else:
                h *= 0.5
        record(config, history, r[:n_t] + target, target)
        objs_seen.append(obj)
    else:
        it = config.max_iter
    return conclude(config, u, r[:n_t] + target, obj, target, status, it, n_eval, history)
