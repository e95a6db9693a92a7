"""Chapter 3's graders: the network Jacobian, one Levenberg-Marquardt step, and trainlm's loop.

Each ``check_*`` takes the student's function, draws its own cases from its own seeded
``np.random.default_rng`` (the chapter's random stream is untouched) and calls
:func:`lab.course.grade` against ``lab``'s own implementation: :meth:`lab.learn.MLP.jacobian`
for exercise 3.1, :func:`lab.learn.lm_step` for 3.2 and :func:`lab.learn.train_lm` (the
MATLAB-faithful ``trainlm``, its stop rules switched off but the epoch count) for 3.3.
The references live here, out of the student's sight: a grader cell in
``notebooks/03_learned_model.ipynb`` is one import and one call.

Exercise 3.3 is graded on cases in which some trial steps fail (the damping then grows and
the epoch tries again): a loop that accepts every step, keeps ``mu`` fixed, or ends an
epoch on a failed try ends at other weights and fails (``tests/test_course_ch03_04.py``
checks those wrong loops).
"""

from __future__ import annotations

import numpy as np

from lab.course.grading import Grade, grade
from lab.learn import LMOptions, TrainingData, init_mlp, lm_step, train_lm

__all__ = ["check_network_jacobian", "check_lm_step", "check_lm_training", "lm_training_cases"]


def _data(rng: np.random.Generator, n: int, n_u: int = 3, n_y: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Random training data: commands (n, n_u) rad in [0, 3], smooth tips (n, n_y) m plus noise."""
    u = rng.uniform(0.0, 3.0, (n, n_u))
    y = 0.05 * np.sin(u @ rng.standard_normal((n_u, n_y))) + 0.002 * rng.standard_normal((n, n_y))
    return u, y


def check_network_jacobian(student, *, case: int | None = None, show: bool = True) -> Grade:
    """Exercise 3.1: ``student(net, u) -> dy/du`` (n_y, n_u) m/rad for one input ``u`` (n_u,)
    rad, against :meth:`MLP.jacobian` on random networks (depths 1-3, tanh and logistic, one
    with 4 inputs and 2 outputs), three random inputs each."""
    rng = np.random.default_rng(31)
    cases = []
    layouts = [((20, 20), "tanh", 3, 3), ((20, 20), "logistic", 3, 3), ((8,), "tanh", 3, 3)]
    layouts += [((5, 9, 4), "logistic", 3, 3), ((6, 6), "tanh", 4, 2)]
    for k, (hidden, act, n_u, n_y) in enumerate(layouts):
        u_data, y_data = _data(rng, 50, n_u, n_y)
        net = init_mlp(u_data, y_data, hidden, act, seed=100 + k)
        cases += [(net, u) for u in rng.uniform(-0.2, 3.2, (3, n_u))]
    return grade(
        "the network Jacobian",
        student,
        lambda net, u: net.jacobian(u),
        cases,
        show=show,
        case=case,
        checker=check_network_jacobian,
        hint="check each factor's shape against the boxed product; forgetting G_u or G_y^-1 scales whole rows "
        "and columns",
    )


def check_lm_step(student, *, case: int | None = None, show: bool = True) -> Grade:
    """Exercise 3.2: ``student(net, u, y, mu) -> dtheta`` (n_params,), against
    :func:`lab.learn.lm_step` on random networks, data and damping, on both sides of
    n_params = N_e (the primal and the kernel form of the same system)."""
    rng = np.random.default_rng(32)
    cases = []
    for hidden, n in (((4,), 30), ((6, 5), 8), ((20, 20), 40), ((3,), 12), ((10,), 60)):
        u, y = _data(rng, n)
        net = init_mlp(u, y, hidden, "tanh", seed=int(rng.integers(1000)))
        cases.append((net, u, y, float(10 ** rng.uniform(-4, 0))))
    return grade(
        "one LM step",
        student,
        lm_step,
        cases,
        show=show,
        case=case,
        checker=check_lm_step,
        rtol=1e-6,
        atol=1e-12,
        hint="e is prediction minus data, flattened in the row order of parameter_jacobian's J; both sides of "
        "the damped system are averages over the N_e residuals, and the step goes downhill",
    )


def lm_training_cases() -> list[tuple]:
    """Exercise 3.3's cases: (net, u (N, 3) rad, y (N, 3) m, epochs). Small networks (and one
    3-20-20-3, whose 563 parameters exceed its 180 residuals) on noisy smooth data, for
    6-12 epochs: in each, some trial steps fail and the damping has to grow."""
    rng = np.random.default_rng(33)
    cases = []
    for hidden, n, epochs in (((5,), 40, 8), ((8, 6), 60, 10), ((20, 20), 60, 6), ((4,), 25, 12)):
        u, y = _data(rng, n)
        cases.append((init_mlp(u, y, hidden, "tanh", seed=int(rng.integers(1000))), u, y, epochs))
    return cases


def _trained_params(net, u, y, epochs: int) -> np.ndarray:
    """lab's trainlm for exactly ``epochs`` epochs on (u, y), no validation set, no gradient stop."""
    trained, _ = train_lm(net, TrainingData(u, y), LMOptions(epochs=int(epochs), min_grad=0.0))
    return trained.get_params()


def check_lm_training(student, *, case: int | None = None, show: bool = True) -> Grade:
    """Exercise 3.3: ``student(net, u, y, epochs) -> theta`` (n_params,), the parameters after
    ``epochs`` epochs of trainlm's loop from ``net``'s, against :func:`lab.learn.train_lm`.
    The student's function gets its own copy of each network, so a loop that changes the
    network it is given cannot change the reference's start."""
    cases = lm_training_cases()
    return grade(
        "trainlm's loop",
        lambda net, u, y, epochs: student(net.copy(), u, y, epochs),
        _trained_params,
        cases,
        show=show,
        case=case,
        checker=check_lm_training,
        given=student,
        rtol=1e-6,
        atol=1e-8,
        hint="an epoch ends only when a trial step lowers the training error: a failed try is undone, "
        "the damping grows and the same epoch tries again; a success relaxes the damping",
    )
