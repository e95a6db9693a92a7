"""Graders of chapter 06 (the six-cable two-stage arm at scale).

One checker per exercise. Each draws its own cases from its own seeded
``np.random.default_rng`` (the chapter's random stream is untouched), runs the student's
function and ``lab``'s own implementation on them, and shows one result through
:func:`lab.course.grade`:

- :func:`check_project_command` (exercise 6.1, the projection onto the allowed commands)
  against :meth:`lab.control.CommandSet.project` (the active-set projection the IK uses), on
  the arm's own set and on random limits with three and six motors;
- :func:`check_regularised_walk` (exercise 6.2, a regularised, warm-started walk along a
  path) against :meth:`lab.control.IKSolver.follow` with the same solver (restarts off), on
  the chapter's paths and on a random smooth path, with random weights and postures.

The references live here, out of the student's sight: a grader cell only calls its checker.
"""

from __future__ import annotations

import numpy as np

from lab.control import CommandSet, IKConfig, IKSolver, trajectories
from lab.course.grading import Grade, grade

__all__ = ["check_project_command", "check_regularised_walk"]


def _project_by_lab(v_rad, u_max_rad, sum_max_rad):
    m = len(v_rad)
    return CommandSet(np.zeros(m), np.full(m, u_max_rad), np.ones((1, m)), [sum_max_rad]).project(v_rad)


def check_project_command(project_command, commands: CommandSet, *, show: bool = True) -> Grade:
    """Exercise 6.1: ``project_command(v (m,) rad, u_max_rad, sum_max_rad) -> x (m,) rad`` on
    random commands for ``commands`` (the six-cable arm's allowed set: ``[0, u_max]^6`` and
    one row over all six motors), then for random limits with three and six motors."""
    rng = np.random.default_rng(61)
    u_max_rad, sum_max_rad = float(commands.hi[0]), float(commands.b[0])
    cases = [(v, u_max_rad, sum_max_rad) for v in rng.uniform(-1, 5, (8, commands.n))]
    for m in (3, 3, 6, 6):
        u_max_c = float(rng.uniform(1, 4))
        sum_max_c = float(rng.uniform(1.2, m - 0.5) * u_max_c)
        cases += [(v, u_max_c, sum_max_c) for v in rng.uniform(-0.5 * u_max_c, 1.5 * u_max_c, (3, m))]
    return grade(
        "projecting onto the allowed set",
        project_command,
        _project_by_lab,
        cases,
        rtol=1e-9,
        atol=1e-9,
        hint="clipping alone is not the projection when the sum is too large; for a fixed multiplier of the "
        "sum row each motor is a one-motor problem, and the multiplier is the one at which the sum is met",
        show=show,
    )


def _walk_by_lab(solver, targets_m, u_start_rad):
    return solver.follow(targets_m, u0=u_start_rad).u_motor


def check_regularised_walk(regularised_walk, model, commands: CommandSet, *, show: bool = True) -> Grade:
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
    )
