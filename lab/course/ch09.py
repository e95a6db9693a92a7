"""Chapter 9's graders: a relaxation filter's step response, iterative learning control over
whole passes, and the filter's frequency response.

Each ``check_*`` takes the student's function, draws its own cases from its own seeded
``np.random.default_rng`` (the chapter's random stream is untouched) and calls
:func:`lab.course.grade` against ``lab``'s own implementation or an independent measurement:
:meth:`lab.dynamics.Relaxation.step` for exercise 9.1; for 9.2, passes over a trajectory
whose every correction is :func:`lab.tracking.closed_loop.correct_command` (the step the
``track --closed-loop ilc`` runs take, here in a command set too wide to bind); for 9.3 the
amplitude and phase read off a sinusoid streamed through :meth:`Relaxation.response`
(:func:`measured_frequency_response`, which the chapter also uses). The references live
here, out of the student's sight: a grader cell in ``notebooks/09_dynamics_and_feedback.ipynb``
is one import and one call.

Exercise 9.2 is built, not transcribed. Its toy arms (tip ``c + A tanh(u)``, a model with
another ``A``) start some commands far enough off that the per-correction limit binds, so
clipping each motor alone, correcting after the last pass, keeping the first pass's
Jacobian or the wrong sign of the error all fail (``tests/test_course_ch08_10.py``).
"""

from __future__ import annotations

import numpy as np

from lab.control import CommandSet
from lab.course.grading import Grade, grade
from lab.dynamics import Relaxation
from lab.tracking.closed_loop import Correction, correct_command

__all__ = ["check_step_response", "check_ilc", "check_frequency_response", "measured_frequency_response"]


def check_step_response(student, *, case: int | None = None, show: bool = True) -> Grade:
    """Exercise 9.1: ``student(t, tau_s, weight)`` -> the fraction of an equilibrium step
    covered at times ``t`` (shape of t), against :meth:`Relaxation.step` for 6 random filters
    of 1-3 modes at 1-30 random times, some before the step."""
    rng = np.random.default_rng(91)
    cases = []
    for _ in range(6):
        k = int(rng.integers(1, 4))
        w = rng.dirichlet(np.ones(k))
        cases.append((rng.uniform(-1.0, 10.0, int(rng.integers(1, 30))), rng.uniform(0.05, 5.0, k), w))
    return grade(
        "the step response of a relaxation filter",
        student,
        lambda t, tau_s, weight: Relaxation(tau_s, weight).step(t),
        cases,
        show=show,
        case=case,
        checker=check_step_response,
        hint="solve each mode's equation for a unit step of the equilibrium, starting at rest; "
        "the tip is the weighted sum of the modes, and nothing moves before the step",
    )


class _ToyArm:
    """A tip ``c + A tanh(u)`` (3,) m for commands u (m,) rad: the robot, or a model of it."""

    def __init__(self, A, c):
        self.A, self.c = np.asarray(A, float), np.asarray(c, float)

    def measure(self, U) -> np.ndarray:
        """One pass on the robot: the tips (N, 3) m of commands U (N, m) rad."""
        return self.c + np.tanh(np.asarray(U, float)) @ self.A.T

    def jacobian(self, u) -> np.ndarray:
        """The tip's Jacobian (3, m) m/rad at one command u (m,) rad."""
        return self.A * (1.0 - np.tanh(np.asarray(u, float)) ** 2)


class _Forward:
    """What :func:`correct_command` reads of a model: its Jacobian (the prediction is unused)."""

    def __init__(self, jacobian):
        self.jacobian = jacobian

    def predict_and_jacobian(self, u):
        return None, self.jacobian(u)


def _ilc_by_lab(measure, jacobian, u0, targets, passes, gain, damping, max_step_rad):
    """ILC with lab's correction step: (mean error per pass (passes,) m, last commands (N, m))."""
    model = _Forward(jacobian)
    U = np.array(u0, dtype=float)
    wide = CommandSet(np.full(U.shape[1], -1e3), np.full(U.shape[1], 1e3))  # no limit binds
    correction = Correction(gain=gain, damping=damping, max_step_rad=max_step_rad)
    errors = []
    for k in range(passes):
        tips = measure(U)
        errors.append(float(np.mean(np.linalg.norm(tips - targets, axis=1))))
        if k < passes - 1:
            U = np.array([correct_command(wide, model, U[i], targets[i], tips[i], correction) for i in range(len(U))])
    return np.array(errors), U


def _ilc_cases(rng: np.random.Generator) -> list[tuple]:
    """(measure, jacobian, u0, targets, passes, gain, damping, max_step_rad): 3, 4 and 6 motors."""
    cases = []
    for m in (3, 3, 4, 6, 6, 3):
        A = rng.normal(0.0, 0.05, (3, m))
        robot = _ToyArm(A, rng.normal(0.0, 0.05, 3))
        model = _ToyArm(A + rng.normal(0.0, 0.01, (3, m)), robot.c)  # a model with another A
        u_true = rng.uniform(0.2, 1.8, (int(rng.integers(3, 10)), m))
        u0 = u_true + rng.normal(0.0, 0.3, u_true.shape)  # the open loop's commands, off by the model's error
        step = float(rng.choice([0.05, 0.1, 0.3, 1.0]))
        gain, damping = float(rng.uniform(0.5, 1.2)), float(10 ** rng.uniform(-3, -1))
        targets = robot.measure(u_true)
        cases.append((robot.measure, model.jacobian, u0, targets, int(rng.integers(2, 6)), gain, damping, step))
    return cases


def check_ilc(student, *, case: int | None = None, show: bool = True) -> Grade:
    """Exercise 9.2: ``student(measure, jacobian, u0, targets, passes, gain, damping,
    max_step_rad)`` -> (mean error per pass (passes,) m, the last pass's commands (N, m) rad),
    against passes of :func:`correct_command` on 6 toy arms of 3-6 motors, 3-9 targets and 2-5
    passes."""
    return grade(
        "iterative learning control over passes",
        student,
        _ilc_by_lab,
        _ilc_cases(np.random.default_rng(92)),
        show=show,
        case=case,
        checker=check_ilc,
        rtol=1e-6,
        atol=1e-9,
        hint="measure a whole pass before correcting any target; correct every target with the Jacobian at its "
        "current command; a step longer than allowed keeps its direction; the last pass is only measured",
    )


def measured_frequency_response(period_s: float, tau_s, weight) -> tuple[float, float]:
    """(amplitude ratio, phase in rad, negative: a lag) of the relaxation filter ``(tau_s (K,)
    s, weight (K,))`` for a sinusoid of ``period_s`` s, measured: a sine streamed through
    :meth:`Relaxation.response` for 30 settling times, then fitted over its last period."""
    relax = Relaxation(tau_s, weight)
    t = np.linspace(0.0, 30 * max(period_s, float(np.max(relax.tau_s))), 6000)
    y = relax.response(t, np.sin(2 * np.pi * t / period_s)[:, None], t)[:, 0]
    last = t > t[-1] - period_s
    basis = np.column_stack([np.sin(2 * np.pi * t[last] / period_s), np.cos(2 * np.pi * t[last] / period_s)])
    a, b = np.linalg.lstsq(basis, y[last], rcond=None)[0]
    return float(np.hypot(a, b)), float(np.arctan2(b, a))  # y = a sin + b cos = |H| sin(w t + phase)


def check_frequency_response(student, *, case: int | None = None, show: bool = True) -> Grade:
    """Exercise 9.3: ``student(period_s, tau_s, weight)`` -> (|H|, arg H in rad), against
    :func:`measured_frequency_response` for 4 random two-mode filters at periods of 2-20 s
    (to 2e-3: the measurement's own accuracy)."""
    rng = np.random.default_rng(93)
    cases = [(float(rng.uniform(2, 20)), rng.uniform(0.1, 3.0, 2), rng.dirichlet([1, 1])) for _ in range(4)]
    return grade(
        "the relaxation's frequency response",
        student,
        measured_frequency_response,
        cases,
        show=show,
        case=case,
        checker=check_frequency_response,
        rtol=2e-3,
        atol=2e-3,
        hint="drive one mode's equation with a complex exponential of the period's angular frequency and look "
        "for a solution of the same form; the modes add with their weights",
    )
