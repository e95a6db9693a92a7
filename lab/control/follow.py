"""Following a trajectory with the IK: warm starts, regularisation chosen by itself, recovery.

:func:`follow_trajectory` (what :meth:`lab.control.ik.IKSolver.follow` runs) solves the
targets in order, warm-starting each from the previous answer (Section II-D).

**Redundant arms** (more motors than tip coordinates: six cables, or a user's four) reach
a target with a whole family of commands. Each point is then first solved regularised
towards ``u_ref = (w_c u_prev + w_p u_posture) / (w_c + w_p)``: continuity (``reg_weight``
``w_c``, the previous command) and posture (``posture_weight`` ``w_p``, default the centre
of the allowed set, where every cable is taut: away from the slack plateaus where a
cable's Jacobian column is zero and a warm start gets stuck). The regulariser also pulls
the tip off the target, so the answer is then *polished*: solved again unregularised from
there, which moves it only a little (the regulariser has already picked the branch of
solutions) and removes that bias. A cold first point is pulled to the posture alone.

**Automatic weights.** A weight given as ``None`` (the default of ``make_solver`` and of
``python -m lab track``) is chosen here: 0 for an arm that is not redundant (its IK is
unchanged: Table I), and for a redundant one ``AUTO_WEIGHT_REL |J|_F^2 / m``, ``J`` the
model's Jacobian at the posture (m/rad; for a model without one, a least-squares linear fit
to the cold-start seeds). That is a thousandth of the mean squared column of ``J``: small
enough that the polish has little to undo, large enough to decide the null-space
directions. On the six-cable network it gives 0.97e-6 m^2/rad^2, the weights the README
recommended by hand (1e-6). Explicit values override, 0 is off.

**Recovery.** A point that misses its target (residual > ``reach_tol_m``) while the answer
should be exact (no regulariser, or a polished one) is solved again -- when the solver's
``retry_cold`` allows it -- from other starts: from the posture first if a cable is slack at
the miss (a Jacobian column below :data:`SLACK_COLUMN_REL` of the largest: the plateau,
where the gradient cannot see that pulling that cable would help) or the arm is
regularised, then from the ``4`` seeds whose tips are nearest the target (or the centre).
The best answer is kept; the iterations, evaluations and time of every try are counted.
"""

from __future__ import annotations

import numpy as np

from lab.control.ik_result import TrajectoryIK, check_targets, count_work

#: Automatic regularisation weight of a redundant arm, relative to |J|_F^2 / m at the posture.
AUTO_WEIGHT_REL = 1e-3
#: A cable is "slack" where its Jacobian column is below this fraction of the largest column.
SLACK_COLUMN_REL = 1e-2
#: Cold starts tried, nearest first, when a point misses its target.
N_COLD_STARTS = 4


def _jacobian_scale(solver) -> np.ndarray:
    """A (3, m) Jacobian of the forward map near the posture, m/rad: the model's own, or
    (no Jacobian) the slope of a least-squares linear fit to the seeds, or to a cross of
    commands around the posture."""
    fwd = solver.forward
    if getattr(fwd, "has_jacobian", True):
        return np.asarray(fwd.predict_and_jacobian(solver.u_posture)[1], dtype=float)
    if solver.seeds is not None and len(solver.seeds[0]) > solver.commands.n:
        u, y = solver.seeds
    else:
        h = 0.25 * (solver.commands.hi - solver.commands.lo)
        u = np.array(
            [
                solver.commands.project(solver.u_posture + s * h[i] * e)
                for i, e in enumerate(np.eye(len(h)))
                for s in (-1, 1)
            ]
        )
        y = np.asarray(fwd.predict(u), dtype=float)
    X = np.column_stack([np.ones(len(u)), u])
    return np.linalg.lstsq(X, y, rcond=None)[0][1:].T


def auto_weight(solver) -> float:
    """The automatic regularisation weight (m^2/rad^2) of ``solver``: module docstring."""
    J = _jacobian_scale(solver)
    return float(AUTO_WEIGHT_REL * np.sum(J * J) / J.shape[1])


def follow_weights(solver) -> tuple[float, float, str]:
    """``(reg_weight, posture_weight, how)`` that :func:`follow_trajectory` uses: explicit
    settings as given, ``None`` ones automatic (module docstring); ``how`` says which."""
    settings = (solver.reg_weight_setting, solver.posture_weight_setting)
    if all(s is not None for s in settings):
        return float(settings[0]), float(settings[1]), "explicit"
    if not solver.redundant:
        w = 0.0
        why = f"auto: none ({solver.commands.n} motors for {solver.n_tip} tip coordinates, not redundant)"
    else:
        w = auto_weight(solver)
        why = f"auto: continuity + posture, then polish ({solver.commands.n} motors for {solver.n_tip} tip coordinates)"
    w_c, w_p = (w if s is None else float(s) for s in settings)
    return w_c, w_p, why if all(s is None for s in settings) else why + "; explicit where given"


def slack_motors(solver, u_motor) -> np.ndarray:
    """Indices of the motors whose Jacobian column at ``u_motor`` is below
    :data:`SLACK_COLUMN_REL` of the largest (a slack cable); empty for a model without a Jacobian."""
    if not getattr(solver.forward, "has_jacobian", True):
        return np.zeros(0, dtype=int)
    J = np.asarray(solver.forward.predict_and_jacobian(np.asarray(u_motor, dtype=float))[1], dtype=float)
    norms = np.linalg.norm(J, axis=0)
    return np.flatnonzero(norms < SLACK_COLUMN_REL * norms.max()) if norms.max() > 0 else np.arange(len(norms))


def _solve_point(solver, target, u_start, u_ref, weight):
    """Regularised solve towards ``u_ref`` with ``weight`` and then (``solver.polish``) the
    unregularised polish, or a plain solve when ``weight`` is 0."""
    if weight <= 0:
        return solver.solve(target, u_start, u_ref=u_start, reg_weight=0.0)
    res = solver.solve(target, u_start, u_ref=u_ref, reg_weight=weight)
    if solver.polish:
        first, res = res, solver.solve(target, res.u_motor, reg_weight=0.0)
        res = count_work(res, [first])
        res.history_m = first.history_m + res.history_m
    return res


def _recover(solver, target, first, start, w_p, w, stats):
    """Retry a missed point from the posture (slack cable or regularised arm) and the
    nearest cold starts; the best answer, with the work of every try counted."""
    slack = len(slack_motors(solver, first.u_motor)) > 0
    stats["slack_plateaus"] += slack
    starts = [solver.u_posture] if (slack or w > 0) else []
    if solver.seeds is not None:
        u_s, y_s = solver.seeds
        near = np.argsort(np.sum((y_s - target) ** 2, axis=1))[:N_COLD_STARTS]
        starts += [solver.commands.project(u_s[i]) for i in near]
    else:
        starts.append(solver.centre)
    tries, tried = [first], [start]
    for u0 in starts:
        if min(r.residual_m for r in tries) <= solver.reach_tol_m:
            break
        if any(np.allclose(u0, t) for t in tried):
            continue
        tried.append(u0)
        u_ref = solver.u_posture if w_p > 0 else u0
        tries.append(_solve_point(solver, target, u0, u_ref, w_p or w))
    best = min(tries, key=lambda r: r.residual_m)
    stats["restarts"] += 1
    stats["recovered"] += bool(best.reachable)
    return count_work(best, [r for r in tries if r is not best])


def follow_trajectory(solver, targets_W, u0=None) -> TrajectoryIK:
    """IK through ``solver`` (:class:`lab.control.ik.IKSolver`) for the targets (N, 3) m in
    order, warm-started from the previous answer (the first from ``u0`` (m,) rad or a cold
    start); weights, polish and recovery as in the module docstring. ``TrajectoryIK.info``
    says what was applied (the weights used, why, and the recovery counts)."""
    targets = np.atleast_2d(check_targets(targets_W))
    w_c, w_p, how = follow_weights(solver)
    w = w_c + w_p
    stats = {"slack_plateaus": 0, "restarts": 0, "recovered": 0}
    results, u_prev = [], u0
    for target in targets:
        if u_prev is None:
            u_start = solver.initial_guess(target)
            u_ref, w_now = (solver.u_posture if w_p > 0 else u_start), (w_p or w)
        else:
            u_start = solver.commands.project(np.asarray(u_prev, dtype=float))
            u_ref, w_now = ((w_c * u_start + w_p * solver.u_posture) / w if w > 0 else u_start), w
        res = _solve_point(solver, target, u_start, u_ref, w_now)
        if not res.reachable and solver.retry_cold and (w_now <= 0 or solver.polish):
            res = _recover(solver, target, res, u_start, w_p, w, stats)
        results.append(res)
        u_prev = res.u_motor
    col = lambda name: np.array([getattr(r, name) for r in results])  # noqa: E731
    uncertain = col("uncertain").astype(bool)
    info = {
        "reg_weight": w_c,
        "posture_weight": w_p,
        "regularisation": how,
        "redundant": bool(solver.redundant),
        **stats,
        "spread_weight": solver.spread_weight,
        "max_spread_m": solver.max_spread_m,
        "n_uncertain": int(uncertain.sum()),
    }
    return TrajectoryIK(
        targets,
        col("u_motor"),
        col("p_pred_W"),
        col("residual_m"),
        col("reachable"),
        col("iterations"),
        col("time_s"),
        results,
        uncertain,
        col("spread_m").astype(float),
        info,
    )
