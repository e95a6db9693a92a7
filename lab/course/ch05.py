"""Graders of chapter 05 (closing the sim-to-real gap with few real samples).

One checker per exercise. Each draws its own cases from its own seeded
``np.random.default_rng`` (the chapter's random stream is untouched), runs the student's
function and ``lab``'s own implementation on them, and shows one result through
:func:`lab.course.grade`:

- :func:`check_maximin_order` (exercise 5.1, the greedy maximin design) against
  :func:`lab.data.maximin.greedy_maximin`, the step behind ``design_commands(..., "maximin")``;
- :func:`check_gp_jacobian` (exercise 5.2, the GP residual's Jacobian) against
  :class:`lab.learn.GPCorrection`, the Jacobian the IK uses;
- :func:`check_prior_weight` (exercise 5.3, choosing the fine-tuning prior by
  cross-validation) against :func:`lab.learn.finetune`'s own choice and its recorded
  cross-validation errors, on subsets of the chapter's real samples.

The references live here, out of the student's sight: a grader cell only calls its checker.
"""

from __future__ import annotations

import numpy as np

from lab.course.grading import Grade, grade
from lab.data.maximin import greedy_maximin
from lab.learn import GPCorrection, finetune, finetune_fixed
from lab.learn.finetune import _folds

__all__ = ["check_maximin_order", "check_gp_jacobian", "check_prior_weight"]


def check_maximin_order(maximin_order, *, case: int | None = None, show: bool = True) -> Grade:
    """Exercise 5.1: ``maximin_order(pool (P, m), first, n) -> n indices`` on random pools
    (3 and 6 motors, up to 200 candidates); the commands picked are compared, in order."""
    rng = np.random.default_rng(51)
    cases = [
        (rng.uniform(0, 3, (p, m)), int(rng.integers(p)), n) for p, m, n in ((40, 3, 5), (200, 3, 20), (90, 6, 12))
    ]
    return grade(
        "maximin design",
        lambda pool, first, n: pool[maximin_order(pool, first, n)],
        lambda pool, first, n: pool[greedy_maximin(pool, first, n)],
        cases,
        hint="keep, for every candidate, its distance to the nearest command chosen so far; take the largest",
        show=show,
        case=case,
        checker=check_maximin_order,
        given=maximin_order,
    )


def _gp_reference(X, alpha, length_scales, s2, u):
    return GPCorrection(X, alpha, length_scales, s2, np.zeros(alpha.shape[1])).predict_and_jacobian(u[None])[1][0]


def check_gp_jacobian(gp_jacobian, *, case: int | None = None, show: bool = True) -> Grade:
    """Exercise 5.2: ``gp_jacobian(X (N, m), alpha (N, 3), length_scales (m,), s2, u (m,))
    -> dm/du (3, m)`` on random processes of 1 to 30 samples (3 and 6 inputs)."""
    rng = np.random.default_rng(52)
    cases = []
    for n_train, m in ((1, 3), (7, 3), (30, 3), (12, 6)):
        X = rng.uniform(0, 3, (n_train, m))
        args = (X, rng.normal(0, 1e-3, (n_train, 3)), rng.uniform(0.3, 3, m), float(rng.uniform(1e-6, 1e-4)))
        cases.append((*args, rng.uniform(0, 3, m)))
    return grade(
        "GP residual Jacobian",
        gp_jacobian,
        _gp_reference,
        cases,
        rtol=1e-9,
        atol=1e-15,
        hint="differentiate one kernel term through its exponent (chain rule), then weight and sum over the "
        "samples as m does; the constant c does not depend on u",
        show=show,
        case=case,
        checker=check_gp_jacobian,
    )


def _lab_choice(sim_model, u_rad, y_m, lambdas, seed):
    """The weight lab's fine-tuning chooses, and its CV error (m) for every candidate."""
    record = finetune(sim_model, u_rad, y_m, last_layer_only=True, lambdas=lambdas, seed=seed).metadata["finetune"]
    return record["lambda"], np.array([record["cv_mean_distance_m"][lam] for lam in lambdas])


def check_prior_weight(
    choose_prior_weight, sim_model, u_real, y_real, *, case: int | None = None, show: bool = True
) -> Grade:
    """Exercise 5.3: ``choose_prior_weight(fit, u (N, m), y (N, 3), lambdas (L,), folds)
    -> (best lambda, cross-validation error (L,) m)`` for output-layer fine-tuning of
    ``sim_model`` on random subsets (8, 13 and all) of the real samples ``u_real`` (N, m) rad,
    ``y_real`` (N, 3) m, with random candidate weights; the reference is what
    :func:`lab.learn.finetune` chose and recorded with the same folds."""
    rng = np.random.default_rng(53)
    u_real, y_real = np.asarray(u_real, float), np.asarray(y_real, float)

    def fit(u_rad, y_m, lam):
        return finetune_fixed(sim_model, u_rad, y_m, lam, last_layer_only=True)

    cases, seeds = [], []
    for n in (8, 13, len(u_real)):
        pick = np.sort(rng.choice(len(u_real), min(n, len(u_real)), replace=False))
        lambdas = tuple(float(v) for v in 10.0 ** np.sort(rng.choice(np.arange(-10, 0), 4, replace=False)))
        seeds.append(int(rng.integers(1000)))
        cases.append((fit, u_real[pick], y_real[pick], lambdas, _folds(len(pick), seeds[-1])))
    # lab's answer for a case: finetune draws the same folds from the case's seed (found by
    # the case's own u array), fits and records every weight's CV error
    seed_of = {id(u): seed for (_, u, *_), seed in zip(cases, seeds)}
    return grade(
        "choosing the prior weight by cross-validation",
        choose_prior_weight,
        lambda fit, u, y, lambdas, folds: _lab_choice(sim_model, u, y, lambdas, seed_of[id(u)]),
        cases,
        rtol=1e-9,
        atol=1e-12,
        hint="for each weight, fit on all samples but one fold and measure on that fold only; average the "
        "tip distances over every held-out sample, then keep the weight with the smallest average",
        show=show,
        case=case,
        checker=check_prior_weight,
    )
