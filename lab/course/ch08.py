"""Chapter 8's graders: a batch of active samples kept apart, the Gaussian process's Jacobian,
an ensemble's mean and spread, and the calibration of a spread.

Each ``check_*`` takes the student's function, draws its own cases from its own seeded
``np.random.default_rng`` (the chapter's random stream is untouched) and calls
:func:`lab.course.grade` against ``lab``'s own implementation:
:func:`lab.learn.active.pick_apart` for exercise 8.1, :class:`lab.learn.residual.GPCorrection`
(what ``GPRModel`` evaluates) for 8.2, :meth:`lab.learn.Ensemble.predict_with_std` for 8.3
and :func:`lab.learn.spread_calibration.calibration` for 8.4. The references live here, out of the
student's sight: a grader cell in ``notebooks/08_data_efficiency.ipynb`` is one import and
one call.

Exercise 8.1 is built, not transcribed: a greedy loop whose distances change with every
pick. Its pools hold tight clusters of high spread beside measured commands, so the top-B
spreads (no keeping apart), a loop that forgets the candidates already picked, one that
ignores the measured data, or a score without the cap at ``radius`` all pick other
candidates and fail (``tests/test_course_ch08_10.py`` checks those wrong answers).
"""

from __future__ import annotations

import numpy as np

from lab.course.grading import Grade, grade
from lab.learn import Ensemble
from lab.learn.active import pick_apart
from lab.learn.residual import GPCorrection
from lab.learn.spread_calibration import calibration

__all__ = ["check_pick_apart", "check_gp_jacobian", "check_ensemble_spread", "check_calibration"]


def _pool_case(rng: np.random.Generator) -> tuple:
    """(x_pool (P, m), spread (P,), x_data (N, m), n, radius): a uniform pool in the unit box
    with 2-3 tight clusters of high spread, one of them next to a measured command."""
    m = int(rng.choice([2, 3, 3, 6]))
    centres = rng.uniform(0.2, 0.8, (3, m))
    clusters = [c + rng.normal(0.0, 0.02, (int(rng.integers(4, 9)), m)) for c in centres]
    x_pool = np.vstack([rng.uniform(0.0, 1.0, (int(rng.integers(20, 60)), m)), *clusters])
    spread = rng.uniform(0.1, 1.0, len(x_pool))
    spread[-sum(len(c) for c in clusters) :] += rng.uniform(1.0, 3.0)  # the clusters disagree most
    x_data = np.vstack([rng.uniform(0.0, 1.0, (int(rng.integers(3, 15)), m)), centres[0] + 0.01])
    order = rng.permutation(len(x_pool))  # clusters anywhere in the pool
    return x_pool[order], spread[order], x_data, int(rng.integers(3, 9)), float(rng.uniform(0.15, 0.4))


def check_pick_apart(student, *, case: int | None = None, show: bool = True) -> Grade:
    """Exercise 8.1: ``student(x_pool, spread, x_data, n, radius)`` -> indices (n,) of the
    candidates picked, in the order picked, against :func:`pick_apart` on 12 random pools."""
    rng = np.random.default_rng(81)
    return grade(
        "a batch kept apart",
        student,
        pick_apart,
        [_pool_case(rng) for _ in range(12)],
        show=show,
        case=case,
        checker=check_pick_apart,
        rtol=0.0,
        atol=0.0,
        hint="after each pick, the candidates near the one just picked must lose their advantage, "
        "exactly as those near a measured command do from the start",
    )


def check_gp_jacobian(student, *, case: int | None = None, show: bool = True) -> Grade:
    """Exercise 8.2: ``student(x, X, alpha, length_scales, signal_variance)`` -> (m (n_y,),
    dm/dx (n_y, n_x)), against :class:`GPCorrection` on 6 random GPs (1-6 inputs, 3-40
    samples) at random points."""
    rng = np.random.default_rng(82)

    def by_lab(x, X, alpha, length_scales, signal_variance):
        m, dm = GPCorrection(X, alpha, length_scales, signal_variance, 0.0).predict_and_jacobian(x[None, :])
        return m[0], dm[0]

    cases = []
    for _ in range(6):
        n_c, n_x = int(rng.integers(3, 40)), int(rng.integers(1, 7))
        cases.append(
            (
                rng.uniform(-1, 1, n_x),
                rng.uniform(-1, 1, (n_c, n_x)),
                rng.normal(0, 1, (n_c, 3)),
                rng.uniform(0.2, 2.0, n_x),
                float(rng.uniform(0.1, 3.0)),
            )
        )
    return grade(
        "the GP posterior mean and its Jacobian",
        student,
        by_lab,
        cases,
        show=show,
        case=case,
        checker=check_gp_jacobian,
        rtol=1e-8,
        atol=1e-12,
        hint="each kernel value depends on x only through its exponent: differentiate that (the chain rule), "
        "one input coordinate at a time; the mean is linear in the kernel values",
    )


class _Fixed:
    """An ensemble member that predicts the given tips f_k (N, 3) m whatever the command."""

    n_u = n_y = 3

    def __init__(self, f_k):
        self.f_k = f_k

    def predict(self, u):
        return self.f_k


def check_ensemble_spread(student, *, case: int | None = None, show: bool = True) -> Grade:
    """Exercise 8.3: ``student(f)`` for member predictions f (K, N, 3) m -> (mean (N, 3), spread
    (N, 3)), against :meth:`Ensemble.predict_with_std` (unscaled) on 5 random ensembles of 2-6
    members at 1-20 commands."""
    rng = np.random.default_rng(83)
    cases = [(rng.normal(0.1, 0.01, (int(rng.integers(2, 7)), int(rng.integers(1, 20)), 3)),) for _ in range(5)]
    return grade(
        "the ensemble's mean and spread",
        student,
        lambda f: Ensemble([_Fixed(f_k) for f_k in f]).predict_with_std(None, scaled=False),
        cases,
        show=show,
        case=case,
        checker=check_ensemble_spread,
        hint="K members are a sample of networks, not the whole population: mind the divisor",
    )


def check_calibration(student, *, case: int | None = None, show: bool = True) -> Grade:
    """Exercise 8.4: ``student(y_true, mean, std)`` (N, 3) m each -> (fraction within 1 sigma,
    within 2 sigma), against :func:`calibration` on Gaussian errors with true, too small and
    too large spreads (4 cases, 20-300 samples)."""
    rng = np.random.default_rng(84)
    cases = []
    for factor in (1.0, 0.5, 2.0, 1.3):
        n_c = int(rng.integers(20, 300))
        sigma = rng.uniform(1e-4, 1e-3, (n_c, 3))
        mean_c = rng.normal(0, 0.05, (n_c, 3))
        cases.append((mean_c + sigma * rng.normal(size=(n_c, 3)), mean_c, factor * sigma))

    def by_lab(y_true, mean, std):
        c = calibration(y_true, mean, std)
        return c["within_1sigma"], c["within_2sigma"]

    return grade(
        "within 1 and 2 sigma",
        student,
        by_lab,
        cases,
        show=show,
        case=case,
        checker=check_calibration,
        hint="measure each coordinate's error in units of its own predicted spread, then count",
    )
