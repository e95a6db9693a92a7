"""Following a trajectory with the IK: warm starts, restarts from slack plateaus, and the
regularisation that picks one of a redundant arm's many answers.

:func:`follow_trajectory` (what :meth:`lab.control.ik.IKSolver.follow` runs) solves the
targets in order, warm-starting each from the previous answer (Section II-D). With weights
``w_c`` (``reg_weight``) and ``w_p`` (``posture_weight``) each point is first solved
regularised towards the previous command and the posture, then *polished* unregularised. A
point that misses its target is solved again from the posture and the nearest seeds
(``retry_cold``). Weights given as ``None`` are automatic: none while targets are reached,
and regularised restarts at a miss on a redundant arm (:func:`auto_weight`); with
``IKConfig.smooth_path`` a redundant arm's every point is regularised, so that its
commands do not jump between neighbouring targets. It uses only the solver's public API.
Why, and what was measured: docs/design/ik.md.
"""

from __future__ import annotations

import numpy as np

from lab.control.ik_result import TrajectoryIK, check_targets, count_work

__all__ = [
    "follow_trajectory",
    "follow_weights",
    "auto_weight",
    "slack_motors",
    "AUTO_WEIGHT_REL",
    "SMOOTH_POSTURE_REL",
    "SLACK_COLUMN_REL",
    "N_COLD_STARTS",
]

#: Automatic restart regularisation weight of a redundant arm, relative to |J|_F^2 / m at the posture.
AUTO_WEIGHT_REL = 1e-3
#: ``IKConfig.smooth_path``'s posture weight, relative to its continuity weight (the
#: automatic weight): a pull just strong enough to keep a redundant arm's warm starts from
#: drifting along its family of answers to a bound (docs/design/ik.md, smooth paths).
SMOOTH_POSTURE_REL = 1e-2
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
    """The automatic regularisation weight of ``solver``.

    Parameters
    ----------
    solver : lab.control.ik.IKSolver
        The solver whose forward map and posture give the Jacobian.

    Returns
    -------
    float
        ``AUTO_WEIGHT_REL |J|_F^2 / m`` (m^2/rad^2), ``J`` the Jacobian near the posture (m/rad).
    """
    J = _jacobian_scale(solver)
    return float(AUTO_WEIGHT_REL * np.sum(J * J) / J.shape[1])


def follow_weights(solver) -> tuple[float, float, float, bool, str]:
    """``(reg_weight, posture_weight, restart_weight, restart_to_posture, how)`` that
    :func:`follow_trajectory` uses: the weights of every point's solve (explicit settings as
    given, ``None`` ones 0, or with ``smooth_path`` on a redundant arm the automatic weight
    towards the previous command and :data:`SMOOTH_POSTURE_REL` of it towards the posture),
    those of a restart after a miss (docs/design/ik.md), and ``how`` in words."""
    settings = (solver.config.reg_weight, solver.config.posture_weight)
    w_c, w_p = (0.0 if s is None else float(s) for s in settings)
    shape = f"{solver.commands.n} inputs for {solver.n_tip} tip coordinates"
    if w_c + w_p > 0:
        how = "explicit: continuity + posture on every point, then polish"
        how += "" if all(s is not None for s in settings) else " (auto where not given: 0)"
        return w_c, w_p, w_p or w_c, w_p > 0, how
    if not solver.redundant or all(s is not None for s in settings):
        how = "explicit: none" if all(s is not None for s in settings) else f"auto: none ({shape}, not redundant)"
        return 0.0, 0.0, 0.0, False, how
    w = auto_weight(solver)
    if solver.config.smooth_path:
        how = (
            f"auto, smooth path: every point regularised towards the previous command (w = {w:.3g} m^2/rad^2) "
            f"and the posture ({SMOOTH_POSTURE_REL:g} w), then polished ({shape}, redundant)"
        )
        return w, SMOOTH_POSTURE_REL * w, w, True, how
    how = (
        f"auto: none while targets are reached; a missed point restarts regularised towards the posture "
        f"(w = {w:.3g} m^2/rad^2), then polished ({shape}, redundant)"
    )
    return 0.0, 0.0, w, True, how


def slack_motors(solver, u_motor) -> np.ndarray:
    """The motors of slack cables at a command.

    Parameters
    ----------
    solver : lab.control.ik.IKSolver
        The solver whose forward map gives the Jacobian.
    u_motor : array_like
        The command (m,), rad.

    Returns
    -------
    numpy.ndarray
        Indices (int) of the motors whose Jacobian column is below :data:`SLACK_COLUMN_REL`
        of the largest; empty for a model without a Jacobian.
    """
    if not getattr(solver.forward, "has_jacobian", True):
        return np.zeros(0, dtype=int)
    J = np.asarray(solver.forward.predict_and_jacobian(np.asarray(u_motor, dtype=float))[1], dtype=float)
    norms = np.linalg.norm(J, axis=0)
    return np.flatnonzero(norms < SLACK_COLUMN_REL * norms.max()) if norms.max() > 0 else np.arange(len(norms))


def _solve_point(solver, target, u_start, u_ref, weight):
    """Regularised solve towards ``u_ref`` with ``weight`` and then (``config.polish``) the
    unregularised polish, or a plain solve when ``weight`` is 0."""
    if weight <= 0:
        return solver.solve(target, u_start, u_ref=u_start, reg_weight=0.0)
    res = solver.solve(target, u_start, u_ref=u_ref, reg_weight=weight)
    if solver.config.polish:
        first, res = res, solver.solve(target, res.u_motor, reg_weight=0.0)
        res = count_work(res, [first])
        res.history_m = first.history_m + res.history_m
    return res


def _recover(solver, target, first, start, w_restart, to_posture, stats):
    """Retry a missed point from the posture (slack cable, or a regularised restart) and the
    nearest cold starts, each regularised towards the posture with ``w_restart`` if
    ``to_posture`` (else towards its own start); the best answer, all work counted."""
    slack = len(slack_motors(solver, first.u_motor)) > 0
    stats["slack_plateaus"] += slack
    starts = [solver.u_posture] if (slack or w_restart > 0) else []
    if solver.seeds is not None:
        u_s, y_s = solver.seeds
        near = np.argsort(np.sum((y_s - target) ** 2, axis=1))[:N_COLD_STARTS]
        starts += [solver.commands.project(u_s[i]) for i in near]
    else:
        starts.append(solver.centre)
    # regularised restarts first; if none reaches, the same starts unregularised (a polish
    # from the regularised answer can stop short where a plain solve from the start does not)
    plans = [(u0, w_restart) for u0 in starts] + ([(u0, 0.0) for u0 in starts] if w_restart > 0 else [])
    tries, tried = [first], [(start, 0.0)]
    for u0, w in plans:
        if min(r.residual_m for r in tries) <= solver.config.reach_tol_m:
            break
        if any(np.allclose(u0, t) and w == wt for t, wt in tried):
            continue
        tried.append((u0, w))
        tries.append(_solve_point(solver, target, u0, solver.u_posture if to_posture else u0, w))
    best = min(tries, key=lambda r: r.residual_m)
    stats["restarts"] += 1
    stats["recovered"] += bool(best.reachable)
    return count_work(best, [r for r in tries if r is not best])


def follow_trajectory(solver, targets_W, u0=None) -> TrajectoryIK:
    """IK for a sequence of targets in order, each warm-started from the previous answer.

    Weights, polish and restarts as in docs/design/ik.md.

    Parameters
    ----------
    solver : lab.control.ik.IKSolver
        The solver (forward map, allowed commands, settings).
    targets_W : array_like
        Tip targets (N, 3), m, frame W.
    u0 : array_like, optional
        The first point's start (m,), rad; default a cold start.

    Returns
    -------
    TrajectoryIK
        Per point: commands, predicted tips, residuals, reachability; its ``info`` says
        what was applied (the weights used, why, and the restart counts).
    """
    targets = np.atleast_2d(check_targets(targets_W, solver.n_tip))
    w_c, w_p, w_restart, to_posture, how = follow_weights(solver)
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
        if not res.reachable and solver.config.retry_cold and (w_now <= 0 or solver.config.polish):
            res = _recover(solver, target, res, u_start, w_restart, to_posture, stats)
        results.append(res)
        u_prev = res.u_motor
    col = lambda name: np.array([getattr(r, name) for r in results])  # noqa: E731
    uncertain = col("uncertain").astype(bool)
    info = {
        "reg_weight": w_c,
        "posture_weight": w_p,
        "restart_weight": w_restart,
        "regularisation": how,
        "redundant": bool(solver.redundant),
        **stats,
        "spread_weight": solver.config.spread_weight,
        "max_spread_m": solver.config.max_spread_m,
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
