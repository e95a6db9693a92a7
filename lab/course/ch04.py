"""Chapter 4's graders: the projection onto the allowed commands, one projected gradient step,
and Table I's tracking error.

Each ``check_*`` takes the student's function (and what it needs from the chapter: the
learned model), draws its own cases from its own seeded ``np.random.default_rng`` (the
chapter's random stream is untouched) and calls :func:`lab.course.grade` against ``lab``'s
own implementation: :meth:`lab.control.CommandSet.project` (exact, by an active-set method)
for exercise 4.1, :func:`lab.control.projected_gradient_step` for 4.2 and the errors of a
:class:`lab.tracking.TrackResult` for 4.3. The references live here, out of the student's
sight: a grader cell in ``notebooks/04_trajectory_following.ipynb`` is one import and one call.

Exercise 4.1's cases include commands where clipping alone breaks the sum rule and where a
common shift takes an angle below zero: clipping, clipping then scaling the command down, or
clipping then shifting every angle by the same amount without clipping again all end at
other points and fail (``tests/test_course_ch03_04.py`` checks those wrong projections).
"""

from __future__ import annotations

import numpy as np

from lab.control import CommandSet, projected_gradient_step, trajectories
from lab.course.grading import Grade, grade
from lab.tracking import TrackResult

__all__ = ["check_projection", "check_gd_step", "check_tracking_error", "projection_cases"]


def _allowed(m: int, u_max: float, sum_max: float) -> CommandSet:
    """The box [0, u_max]^m with one safety rule: the angles sum to at most ``sum_max`` rad."""
    return CommandSet(np.zeros(m), np.full(m, float(u_max)), np.ones((1, m)), [float(sum_max)])


def projection_cases() -> list[tuple]:
    """Exercise 4.1's cases: (v (m,) rad, u_max rad, sum_max rad). The chapter's four
    examples, two built so that a common shift takes an angle below zero, and 40 random ones
    (three and six motors, inside the set, outside the box only, beyond the sum rule)."""
    rng = np.random.default_rng(40)
    cases = [
        (np.array(v, dtype=float), 3.0, 6.5)
        for v in ([3.5, 1.0, -0.5], [3.0, 3.0, 3.0], [2.8, 2.5, 0.3], [4.0, 3.5, 0.2])
    ]
    cases += [(np.array([4.0, 4.0, 0.5]), 3.0, 3.5), (np.array([2.9, 0.1, 2.7, 0.4, 1.5, -0.3]), 2.5, 4.0)]
    for _ in range(40):
        m = int(rng.choice([3, 3, 6]))
        u_max = float(rng.uniform(2.0, 4.0))
        v = rng.uniform(-1.0, u_max + 1.5, m)
        cases.append((v, u_max, float(rng.uniform(0.3, 0.9) * m * u_max)))
    return cases


def check_projection(student, *, case: int | None = None, show: bool = True) -> Grade:
    """Exercise 4.1: ``student(v, u_max, sum_max) -> P(v)`` (m,) rad, the nearest command to
    ``v`` with every angle in [0, u_max] and their sum at most ``sum_max``, against
    :meth:`CommandSet.project` to 1e-9 rad."""
    return grade(
        "the projection onto the allowed commands",
        student,
        lambda v, u_max, sum_max: _allowed(len(v), u_max, sum_max).project(v),
        projection_cases(),
        show=show,
        case=case,
        checker=check_projection,
        rtol=0.0,
        atol=1e-9,
        hint="when the sum rule is active, every angle that is not held at a limit moves by the same amount; "
        "find that amount (the clipped sum falls steadily as it grows) and clip again",
    )


def check_gd_step(student, model, u_max_rad: float, *, case: int | None = None, show: bool = True) -> Grade:
    """Exercise 4.2: ``student(model, u, target, alpha, u_min, u_max)`` -> the next command (3,)
    rad, against :func:`projected_gradient_step` on the box ``CommandSet(u_min, u_max)``:
    ten random commands, targets (the tip of ``model`` at a random command), motor limits
    below ``u_max_rad`` and steps, some long enough to hit the limits."""
    rng = np.random.default_rng(41)
    cases = []
    for _ in range(10):
        u_min, u_max = rng.uniform(0.0, 0.5, 3), rng.uniform(2.5, u_max_rad, 3)
        target = model.predict(rng.uniform(0.0, u_max_rad, 3))
        alpha = float(10 ** rng.uniform(1, 4))  # 1 / |J|_F^2 is about 100 rad^2/m^2
        cases.append((model, rng.uniform(u_min, u_max), target, alpha, u_min, u_max))
    return grade(
        "one projected gradient step",
        student,
        lambda model, u, target, alpha, u_min, u_max: projected_gradient_step(
            model, u, target, alpha, CommandSet(u_min, u_max)
        ),
        cases,
        show=show,
        case=case,
        checker=check_gd_step,
        hint="step against the gradient of O (it points uphill), then bring each angle back inside its limits",
    )


def _track_result(targets_W: np.ndarray, achieved_W: np.ndarray) -> TrackResult:
    """A run that recorded ``achieved_W`` (N, 3) m for ``targets_W`` (N, 3) m (the rest empty)."""
    n = len(targets_W)
    return TrackResult(
        "graded",
        targets_W,
        np.zeros((n, 3)),
        achieved_W,
        targets_W,
        np.zeros(n),
        np.ones(n, dtype=bool),
        np.zeros(n, dtype=int),
        np.ones(n, dtype=bool),
        np.zeros(n),
        {},
    )


def check_tracking_error(student, *, case: int | None = None, show: bool = True) -> Grade:
    """Exercise 4.3: ``student(targets_W, achieved_W) -> (mean, max)`` distance in cm, against
    :attr:`TrackResult.mean_error_m` and ``max_error_m`` on the four built-in trajectories
    (5-40 targets each) with recorded tips off by 0.1 mm to 1 cm."""
    rng = np.random.default_rng(42)
    cases = []
    for name in ("circle", "square", "rose", "helix"):
        t = trajectories.builtin(name, int(rng.integers(5, 40)))
        cases.append((t, t + rng.normal(0.0, 10 ** rng.uniform(-4, -2), t.shape)))

    def reference(targets_W, achieved_W):
        run = _track_result(targets_W, achieved_W)
        return 100 * run.mean_error_m, 100 * run.max_error_m

    return grade(
        "Table I's tracking error",
        student,
        reference,
        cases,
        show=show,
        case=case,
        checker=check_tracking_error,
        hint="the 3-D distance per target (not per axis, not squared), then the mean and the maximum; m -> cm",
    )
