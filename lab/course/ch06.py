"""Graders of chapter 06 (the six-cable two-stage arm at scale).

One checker per exercise. Each draws its own cases from its own seeded
``np.random.default_rng`` (the chapter's random stream is untouched), runs the student's
function and ``lab``'s own implementation on them, and shows one result through
:func:`lab.course.grade`:

- :func:`check_walk_in_place` (exercise 6.1, a walk along the family of commands that keep
  the tip still) against the predictor-corrector walk here (``_walk_in_place_by_lab``)
  through the chapter's network: random starts and directions, "from the long cables to the
  short ones" and back, "every cable tighter"; most walks end at a motor limit or the safety
  rule. Its cases fail a walk without the correction, a single correction, one along the
  Jacobian at the new command instead of the step's start, a step along the whole direction
  or not scaled to the step length, and a walk that ignores the allowed set or keeps the
  command that leaves it (``tests/test_course_ch05_07.py``);
- :func:`check_regularised_walk` (exercise 6.2, a regularised, warm-started walk along a
  path) against :meth:`lab.control.IKSolver.follow` with the same solver (restarts off), on
  the chapter's paths and on a random smooth path, with random weights and postures.

The references live here, out of the student's sight: a grader cell only calls its checker.
"""

from __future__ import annotations

import numpy as np

from lab.control import CommandSet, IKConfig, IKSolver, trajectories
from lab.course.grading import Grade, grade

__all__ = ["check_walk_in_place", "check_regularised_walk"]

#: The walk's correction puts the tip back to this distance (m) of where it started.
TIP_TOL_M = 1e-12
#: Correction iterations before the reference gives up (it converges in a few).
_MAX_CORRECTIONS = 50


def _walk_in_place_by_lab(model, commands: CommandSet, u_start_rad, direction_rad, step_rad: float, n_steps: int):
    """The walk of exercise 6.1: commands (K, m) rad, K <= n_steps + 1, starting at
    ``u_start_rad`` (m,), each ``step_rad`` along the part of ``direction_rad`` (m,) the
    Jacobian (3, m) m/rad at the current command cannot see (its null space), then corrected
    along the Jacobian's rows until the tip of ``model`` is within :data:`TIP_TOL_M` of the
    start's; stops before a corrected command outside ``commands``. RuntimeError where the
    direction has (almost) no free part, the correction does not converge, or the set's
    boundary lies between a prediction and its correction (no such case is drawn)."""
    u_rad = np.array(u_start_rad, dtype=float)
    tip_m = model.predict(u_rad)
    out = [u_rad]
    for _ in range(n_steps):
        J = model.jacobian(u_rad)
        rows_inv = np.linalg.pinv(J)  # (m, 3): J's row space back from tip space
        free = direction_rad - rows_inv @ (J @ direction_rad)  # null-space part of the direction
        if np.linalg.norm(free) < 0.2 * np.linalg.norm(direction_rad):
            raise RuntimeError("the direction is (almost) all seen by the Jacobian")
        v_rad = predicted_rad = u_rad + step_rad * free / np.linalg.norm(free)
        for _ in range(_MAX_CORRECTIONS):
            miss_m = model.predict(v_rad) - tip_m
            if np.linalg.norm(miss_m) < TIP_TOL_M:
                break
            v_rad = v_rad - rows_inv @ miss_m  # chord Newton on J's rows: the free part stays step_rad
        else:
            raise RuntimeError("the correction did not converge")
        if commands.contains(v_rad) != commands.contains(predicted_rad):
            raise RuntimeError("the allowed set cuts between prediction and correction: an ambiguous case")
        if not commands.contains(v_rad):
            break
        u_rad = v_rad
        out.append(u_rad)
    return np.array(out)


def _walk_cases(model, commands: CommandSet, rng: np.random.Generator) -> list[tuple]:
    """Exercise 6.1's cases (model, commands, u_start (m,) rad, direction (m,), step rad,
    steps): "from the long cables to the short ones" and back, 60 steps each; "every cable
    tighter" from near the safety rule (it ends there); six random directions of 15 to 40
    steps from random starts (some end at a motor limit). A drawn case the reference cannot
    walk unambiguously is drawn again (20 tries, else left out)."""
    m = commands.n
    to_short = np.r_[-np.ones(m // 2), np.ones(m - m // 2)]
    # (direction, start drawn in [lo, hi]^m rad, projected and scaled by, steps)
    plans = [(to_short, 0.3, 2.7, 1.0, 60), (-to_short, 0.3, 2.7, 1.0, 60), (np.ones(m), 1.8, 2.9, 0.94, 40)]
    plans += [(rng.normal(size=m) * rng.uniform(0.5, 3), 0.3, 2.7, 1.0, int(rng.integers(15, 40))) for _ in range(6)]
    cases = []
    for direction, lo_rad, hi_rad, scale, n_steps in plans:
        for _ in range(20):
            u_start = scale * commands.project(rng.uniform(lo_rad, hi_rad, m))
            case = (model, commands, u_start, direction, float(rng.uniform(0.03, 0.1)), n_steps)
            try:
                _walk_in_place_by_lab(*case)
            except RuntimeError:
                continue
            cases.append(case)
            break
    return cases


def check_walk_in_place(
    walk_in_place, model, commands: CommandSet, *, case: int | None = None, show: bool = True
) -> Grade:
    """Exercise 6.1: ``walk_in_place(model, commands, u_start (m,) rad, direction (m,),
    step_rad, n_steps) -> u (K, m) rad`` through the network ``model`` on the allowed set
    ``commands``, against ``_walk_in_place_by_lab`` to 1e-6 rad on nine walks of 15 to 60 steps of
    0.03 to 0.1 rad (see :func:`_walk_cases`); a walk that stops too early or too late has
    the wrong number of rows."""
    return grade(
        "walking along the family of solutions",
        walk_in_place,
        _walk_in_place_by_lab,
        _walk_cases(model, commands, np.random.default_rng(61)),
        rtol=0.0,
        atol=1e-6,
        hint="step along the part of the direction the Jacobian at the current command cannot see, scaled to the "
        "step length; the tip then has moved a little: put it back moving only along what that same Jacobian "
        "sees, iterating until the tip is back; do not keep a corrected command outside the allowed set",
        show=show,
        case=case,
        checker=check_walk_in_place,
    )


def _walk_by_lab(solver, targets_m, u_start_rad):
    return solver.follow(targets_m, u0=u_start_rad).u_motor


def check_regularised_walk(
    regularised_walk, model, commands: CommandSet, *, case: int | None = None, show: bool = True
) -> Grade:
    """Exercise 6.2: ``regularised_walk(solver, targets (N, 3) m, u_start (m,) rad) -> u (N, m)
    rad`` through the network ``model`` on the allowed set ``commands``: three of the
    chapter's paths (12 to 16 targets) and a random smooth path of reachable targets, each with
    its own random continuity and posture weights (m^2/rad^2), posture and start. The solver
    given has restarts after a miss switched off (``retry_cold=False``), so its
    ``follow`` is the walk alone."""
    rng = np.random.default_rng(62)
    paths = [trajectories.builtin(name, n) for name, n in (("six-ring", 12), ("six-spiral", 16), ("six-saddle", 12))]
    ends = [commands.project(v) for v in rng.uniform(0.5, 2.5, (2, commands.n))]
    s = np.linspace(0, 1, 10)[:, None]
    paths.append(np.asarray(model.predict(ends[0] + s * (ends[1] - ends[0])), dtype=float))  # reachable targets
    cases = []
    for targets in paths:
        w_c, w_p = (float(w) for w in 10 ** rng.uniform(-7, -5, 2))
        posture = tuple(float(v) for v in commands.project(rng.uniform(0.5, 2.5, commands.n)))
        config = IKConfig("lm", reg_weight=w_c, posture_weight=w_p, u_posture=posture, retry_cold=False)
        cases.append((IKSolver(model, commands, config), targets, commands.project(rng.uniform(0, 3, commands.n))))
    return grade(
        "a regularised, warm-started walk",
        regularised_walk,
        _walk_by_lab,
        cases,
        rtol=1e-6,
        atol=1e-6,
        hint="start every target from the previous answer; the two pulls are one pull towards a weighted "
        "blend of the previous command and the posture; the regularised answer is polished by a solve "
        "without any pull",
        show=show,
        case=case,
        checker=check_regularised_walk,
    )
