"""Chapter 1's graders: the cable length, Newton's method for the statics, a warm-started walk.

Each ``check_*`` takes the student's function, draws its own cases from its own seeded
``np.random.default_rng`` (the chapter's random stream is untouched) and calls
:func:`lab.course.grade` against ``lab``'s own implementation: :class:`lab.fem.CableRoute`
for exercise 1.1, :func:`lab.fem.solve_static` (cable-condensed Newton, chord steps) for
1.2 and cold solves from rest for 1.3. The references live here, out of the student's
sight: a grader cell in ``notebooks/01_fem_simulation.ipynb`` is one import and one call.

Exercise 1.2 starts every case a few millimetres from its equilibrium (the equilibrium of
a neighbouring command), so returning the start, or one step, fails. Exercise 1.3 is a
property check as well as a comparison: the walk's tips must be the equilibria, and it
must need at most :data:`WARM_FRACTION` of the Newton iterations that cold starts take
(a first-order prediction needs 0.5-0.65 of them on the chapter's meshes, the previous
equilibrium alone 0.8-0.9): a walk that starts every solve from rest, or from the
previous equilibrium only, fails (``tests/test_course_ch01_02.py`` checks those).
"""

from __future__ import annotations

import numpy as np

from lab.course.grading import Grade, grade
from lab.errors import LabRuntimeError
from lab.fem import CableRoute, solve_static

__all__ = ["check_cable_length", "check_newton_solve", "check_warm_walk", "WARM_FRACTION", "walk_cases"]

#: a warm-started walk passes with at most this fraction of the cold starts' Newton iterations
WARM_FRACTION = 0.75


def _cable_length_lab(anchor_W, via_W):
    # a route whose via point k is node k with weight 1: CableRoute's points are via_W itself
    route = CableRoute(anchor_W, np.arange(len(via_W))[:, None], np.ones((len(via_W), 1)), 0.0)
    return route.length_gradient(via_W)


def check_cable_length(student, *, case: int | None = None, show: bool = True) -> Grade:
    """Exercise 1.1: ``student(anchor_W (3,), via_W (K, 3)) -> (L m, dL/dvia (K, 3))`` on
    random routes of 1 to 6 via points, against :meth:`lab.fem.CableRoute.length_gradient`."""
    rng = np.random.default_rng(11)
    cases = [(rng.normal(size=3), rng.normal(size=(k, 3))) for k in (1, 2, 3, 5, 6)]
    return grade(
        "cable length and gradient",
        student,
        _cable_length_lab,
        cases,
        show=show,
        case=case,
        checker=check_cable_length,
        hint="a segment grows when its far end moves away along it and shrinks when its near end does; "
        "a via point ends one segment and starts the next, except the last",
    )


def _neighbour(robot, u: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A safe command 0.2-0.4 rad from ``u`` on every cable: up from 0, down from u_max."""
    step = rng.uniform(0.2, 0.4, u.shape) * rng.choice([-1.0, 1.0], u.shape)
    step = np.where(u <= 0.0, np.abs(step), np.where(u >= robot.u_max_rad, -np.abs(step), step))
    u_start = np.clip(u + step, 0.0, robot.u_max_rad)
    return u_start if robot.is_safe(u_start[None])[0] else np.clip(u - np.abs(step), 0.0, robot.u_max_rad)


def newton_cases(fem, solutions, seed: int = 12) -> list[tuple]:
    """Exercise 1.2's cases (fem, u_motor (m,) rad, q0 (n_free,) m): every equilibrium of
    ``solutions`` (StaticSolutions), started from the equilibrium of a neighbouring command."""
    rng = np.random.default_rng(seed)
    cases = []
    for sol in solutions:
        u = np.asarray(sol.u_motor, float)
        q0 = solve_static(fem, _neighbour(fem.robot, u, rng)).q
        cases.append((fem, u, q0))
    return cases


def check_newton_solve(student, fem, solutions, *, case: int | None = None, show: bool = True) -> Grade:
    """Exercise 1.2: ``student(fem, u_motor, q0) -> q`` (n_free,) m, the equilibrium found by
    Newton's method from ``q0``, against :func:`lab.fem.solve_static` from the same start,
    to 1 µm per coordinate. ``solutions``: the chapter's solved commands (StaticSolutions,
    or a dict of them); each is started from the equilibrium of a command 0.2-0.4 rad away."""
    sols = list(solutions.values()) if isinstance(solutions, dict) else list(solutions)
    return grade(
        "Newton's method",
        student,
        lambda fem, u, q0: solve_static(fem, u, q0).q,
        newton_cases(fem, sols),
        show=show,
        case=case,
        checker=check_newton_solve,
        rtol=0.0,
        atol=1e-6,
        hint="repeat: a step from the exact Hessian and the gradient, shortened while it does not lower the "
        "energy, until a step moves no coordinate more than tol_step_m",
    )


def walk_cases(fem, seed: int = 13, n_paths: int = 2, n_points: int = 8) -> list[tuple]:
    """Exercise 1.3's cases (fem, u_path (n_points, m) rad): closed loops of commands around
    the middle of the range, each cable's angle a cosine, the cables a third of a turn apart."""
    rng = np.random.default_rng(seed)
    m = fem.robot.n_inputs
    cases = []
    for _ in range(n_paths):
        centre, radius = rng.uniform(0.4, 0.6) * fem.robot.u_max_rad, rng.uniform(0.2, 0.33) * fem.robot.u_max_rad
        theta = rng.uniform(0, 2 * np.pi) + np.linspace(0, 2 * np.pi, n_points, endpoint=False)
        wave = np.cos(theta[:, None] - 2 * np.pi * np.arange(m) / m)
        while not np.all(fem.robot.is_safe(centre + radius * wave)):  # a robot with a tighter safety rule
            centre, radius = 0.8 * centre, 0.8 * radius
        cases.append((fem, centre + radius * wave))
    return cases


class NotWarmStarted(LabRuntimeError):
    """A walk that reached the equilibria but needed about as many Newton iterations as
    cold starts from rest."""


def check_warm_walk(student, fem, *, case: int | None = None, show: bool = True) -> Grade:
    """Exercise 1.3: ``student(fem, u_path (N, m) rad) -> [StaticSolution] * N``. Its tips
    (N, 3) m must be those of cold solves from rest (:func:`lab.fem.solve_static`, to
    0.1 µm), and its solutions' Newton iterations at most :data:`WARM_FRACTION` of the cold
    solves' (else it fails with :class:`NotWarmStarted`)."""
    cases = walk_cases(fem)
    cold: dict[int, list] = {}  # each path's cold solves, solved for the cases run (all, or case=)

    def walked(fem, u_path):
        if id(u_path) not in cold:  # before the student's walk, which could change u_path
            cold[id(u_path)] = [solve_static(fem, u) for u in u_path]
        sols = list(student(fem, u_path))
        if len(sols) != len(u_path):
            raise ValueError(f"expected {len(u_path)} solutions (one per command), got {len(sols)}")
        tips = np.array([np.asarray(s.p_tip_W, float) for s in sols])
        n_warm, n_cold = sum(int(s.iterations) for s in sols), sum(s.iterations for s in cold[id(u_path)])
        if np.allclose(tips, reference(fem, u_path), rtol=0.0, atol=1e-7) and n_warm > WARM_FRACTION * n_cold:
            raise NotWarmStarted(
                f"the tips are right, but the walk took {n_warm} Newton iterations, {n_warm / n_cold:.0%} of the "
                f"{n_cold} of cold starts from rest (at most {WARM_FRACTION:.0%} passes): start each solve from "
                "the previous equilibrium moved along its sensitivity to the new command"
            )
        return tips

    def reference(fem, u_path):
        return np.array([s.p_tip_W for s in cold[id(u_path)]])

    return grade(
        "a warm-started walk",
        walked,
        reference,
        cases,
        show=show,
        case=case,
        checker=check_warm_walk,
        given=student,
        rtol=0.0,
        atol=1e-7,
        hint="every solve must converge (solve_static raises if not); the first command starts from rest",
    )
