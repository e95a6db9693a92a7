"""Derivative-free IK: secant Levenberg-Marquardt with a compass poll, inside the allowed set.

For forward models without a useful Jacobian (``has_jacobian = False``, e.g. a k-nearest-
neighbour regressor, piecewise smooth with kinks at the data): :class:`lab.control.ik.IKSolver`
with ``method="dfo"`` minimises the same objective as LM/GD,
``O(u) = 1/2 |r(u)|^2 + w/2 |u - u_ref|^2`` with ``r = y(u) - y'`` (and the spread rows of
:mod:`lab.control.spread`), calling only the model's batched ``predict``.

Each iteration (all points are allowed commands, every batch one ``predict`` call):

1. **Secant Jacobian** at scale ``h``: the residuals at ``P_C(u + h s_i e_i)`` (``s_i = +1``,
   or ``-1`` where that leaves ``C``), and ``J_h`` the least-squares fit of their differences
   (forward differences when no projection bites). ``h`` follows the steps: it is the
   length of the last accepted step (between :data:`MIN_STEP_REL` and :data:`MAX_STEP_REL`
   of the motor range), halved after a failed iteration -- so far from the answer the
   Jacobian is a secant over the scale of the step, which also sees past a k-NN's kinks.
2. **LM step** with ``J_h``, exactly as :mod:`lab.control.ik`'s bounded Levenberg-Marquardt
   (damping ``mu``, Nielsen's rule, the QP over ``C`` when the free step leaves it).
3. If that step does not lower ``O``, a **compass poll**: ``P_C(u +- h e_i)``; the best of
   them is taken if it lowers ``O`` (so the search still moves where the secant model is
   wrong, e.g. on a piecewise-constant map; the damping starts afresh there), else ``h``
   is halved.

Stops: ``converged`` at tip residual <= ``tol_m`` (without a spread penalty); ``stationary`` when the secant model's
projected gradient passes the solver's stationarity test, ``h`` falls below
:data:`MIN_STEP_REL` of the motor range (no move at any larger scale lowers ``O``), or the
last :data:`STALL_ITERATIONS` iterations gained less than :data:`STALL_REL` of ``O``;
``max_iter``. ``iterations`` counts iterations, ``evaluations`` model evaluations (points).
"""

from __future__ import annotations

import numpy as np

from lab.control.spread import members_of
from lab.errors import InputError

#: Secant step bounds, as fractions of the largest motor range.
MIN_STEP_REL = 1e-9
MAX_STEP_REL = 0.05
#: Secant step of the first iteration, as a fraction of the largest motor range.
START_STEP_REL = 0.01
#: Stop ("stationary") when ``STALL_ITERATIONS`` iterations lowered ``O`` by less than
#: ``STALL_REL`` of its value: a k-NN map has a shallow local minimum at every sample,
#: where the poll keeps finding crumbs.
STALL_ITERATIONS, STALL_REL = 10, 1e-3


def _residuals(solver, target, U) -> np.ndarray:
    """Residual rows (P, 3 [+ 3K]) m at commands U (P, m): tip error, then the spread rows."""
    Y = np.asarray(solver.forward.predict(U), dtype=float).reshape(len(U), -1)
    R = Y - target
    if solver.spread_weight > 0:
        members = members_of(solver.forward)
        Yk = np.array([np.asarray(m.predict(U), dtype=float).reshape(len(U), -1) for m in members])
        S = np.sqrt(solver.spread_weight / len(members)) * (Yk - Yk.mean(axis=0))  # (K, P, 3)
        R = np.hstack([R, S.transpose(1, 0, 2).reshape(len(U), -1)])
    return R


def _objective(solver, R, U, u_ref) -> np.ndarray:
    obj = 0.5 * np.sum(R * R, axis=1) + 0.5 * solver.reg_weight * np.sum((U - u_ref) ** 2, axis=1)
    return np.where(np.all(np.isfinite(R), axis=1), obj, np.inf)


def _secant_points(commands, u, h) -> np.ndarray:
    """Allowed points (m, m) at distance about h from u along each motor."""
    pts = []
    for i in range(commands.n):
        e = np.zeros(commands.n)
        e[i] = h
        pts.append(u + e if commands.contains(u + e) else commands.project(u - e, x0=u))
    return np.array(pts)


def dfo_solve(solver, target, u, u_ref):
    """Derivative-free solve for ``target`` (3,) m from the allowed ``u`` (m,) rad, pulled to
    ``u_ref`` with ``solver.reg_weight``; returns :class:`lab.control.ik.IKResult`
    (``time_s`` is filled in by :meth:`IKSolver.solve`)."""
    cs, w = solver.commands, solver.reg_weight
    R0 = _residuals(solver, target, u[None])
    r, obj = R0[0], float(_objective(solver, R0, u[None], u_ref)[0])
    if not np.isfinite(obj):
        raise InputError(f"the forward map gives no finite tip at the start command {u.tolist()} rad")
    h, h_min, h_max = START_STEP_REL * cs.scale, MIN_STEP_REL * cs.scale, MAX_STEP_REL * cs.scale
    n_eval, mu, nu, eye, status, history = 1, None, 2.0, np.eye(cs.n), "max_iter", []
    objs_seen = [obj]
    solver._record(history, r[:3] + target, target)
    for it in range(solver.max_iter):  # noqa: B007 (it is the iteration count after the loop)
        if solver.spread_weight == 0 and np.linalg.norm(r[:3]) <= solver.tol_m:
            status = "converged"
            break
        stalled = len(objs_seen) > STALL_ITERATIONS and (
            objs_seen[-STALL_ITERATIONS - 1] - obj < STALL_REL * objs_seen[-STALL_ITERATIONS - 1]
        )
        if h < h_min or stalled:
            status = "stationary"
            break
        P = _secant_points(cs, u, h)
        RP = _residuals(solver, target, P)
        n_eval += len(P)
        J = np.linalg.lstsq(P - u, RP - r, rcond=None)[0].T  # (n_r, m): d r / d u over scale h
        g = J.T @ r + w * (u - u_ref)
        JtJ = J.T @ J + w * eye
        lip = float(np.sum(J * J)) + w
        if np.all(np.isfinite(J)) and solver._stationary(u, g, lip, obj):
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
            R1 = _residuals(solver, target, np.array(trials))
            n_eval += 1
            obj1 = float(_objective(solver, R1, np.array(trials), u_ref)[0])
            rho = (obj - obj1) / predicted
            if rho > 0:  # accept: Nielsen's update, and the secant scale follows the step
                u, r, obj, moved = u + d, R1[0], obj1, True
                mu *= max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3)
                nu, h = 2.0, float(np.clip(np.max(np.abs(d)), h_min, h_max))
        if not moved:
            mu, nu = mu * nu, nu * 2.0
            poll = np.array([cs.project(u + s * h * e, x0=u) for e in eye for s in (1.0, -1.0)])
            RP = _residuals(solver, target, poll)
            n_eval += len(poll)
            objs = _objective(solver, RP, poll, u_ref)
            best = int(np.argmin(objs))
            if objs[best] < obj:  # the secant model was wrong at this scale: a fresh damping
                u, r, obj, mu, nu = poll[best], RP[best], float(objs[best]), None, 2.0
            else:
                h *= 0.5
        solver._record(history, r[:3] + target, target)
        objs_seen.append(obj)
    else:
        it = solver.max_iter
    return solver._result(u, r[:3] + target, obj, target, status, it, n_eval, history)
