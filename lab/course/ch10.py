"""Chapter 10's graders: the repeatability floor from exact revisits, a model's error on
held-out measurement sequences, and a history model's inputs.

Each ``check_*`` takes the student's function, draws its own cases from its own seeded
``np.random.default_rng`` (the chapter's random stream is untouched) and calls
:func:`lab.course.grade` against ``lab``'s own implementation or an independent computation:
:func:`lab.data.repeatability.revisit_floor` for exercise 10.1; for 10.2, scikit-learn's
``LeaveOneGroupOut`` splits with :func:`fit_linear` (``lab``'s least-squares fit) on each;
:func:`lab.learn.history.history_features` for 10.3. The references live here, out of the
student's sight: a grader cell in ``notebooks/10_real_robot_data.ipynb`` is one import and
one call.

Exercise 10.2 is built, not transcribed: a split study. Its data have a state per sequence
(an offset the commands do not explain) and sequences of unequal length, so training on
every row (a leak), averaging per-sequence RMS values, an RMS per coordinate instead of the
3-D distance, or held-out blocks of rows instead of sequences all give other numbers and
fail (``tests/test_course_ch08_10.py`` checks those wrong answers).
"""

from __future__ import annotations

import numpy as np

from lab.course.grading import Grade, grade
from lab.data.repeatability import revisit_floor
from lab.learn.history import history_features
from lab.studies.baselines import fit_poly

__all__ = ["check_revisit_floor", "check_held_out_sequences", "check_history_features", "fit_linear"]


def check_revisit_floor(student, *, case: int | None = None, show: bool = True) -> Grade:
    """Exercise 10.1: ``student(u, y)`` -> the floor (m) from every pair of rows with identical
    commands, against :func:`revisit_floor` on 5 random data sets (6 motors, 12-60 rows) with
    planted repeats, one command sent three times."""
    rng = np.random.default_rng(101)
    cases = []
    for n_rows, n_repeat in ((30, 4), (60, 10), (25, 1), (12, 3), (40, 5)):
        u_c = rng.uniform(-0.6, 0.6, (n_rows, 6))
        picks = rng.choice(n_rows, (n_repeat, 2), replace=False)
        u_c[picks[:, 1]] = u_c[picks[:, 0]]
        if n_rows == 40:  # a third visit of one command: three pairs, not two
            u_c[next(i for i in range(n_rows) if i not in picks)] = u_c[picks[0, 0]]
        cases.append((u_c, 0.1 + 0.01 * rng.normal(size=(n_rows, 3))))
    return grade(
        "floor from revisits",
        student,
        revisit_floor,
        cases,
        show=show,
        case=case,
        checker=check_revisit_floor,
        hint="group the rows by their command first; every pair within a group counts once",
    )


def fit_linear(u, y):
    """``lab``'s linear least-squares fit of tips y (N, 3) m on inputs u (N, m): a model with
    ``predict(u (M, m)) -> (M, 3)`` m (:func:`lab.studies.baselines.fit_poly`, degree 1)."""
    return fit_poly(u, y, 1)


def _held_out_by_sklearn(u, y, seq_ids, fit):
    from sklearn.model_selection import LeaveOneGroupOut

    d2 = []
    for train, test in LeaveOneGroupOut().split(u, y, groups=seq_ids):
        d2.append(np.sum((fit(u[train], y[train]).predict(u[test]) - y[test]) ** 2, axis=1))
    return float(np.sqrt(np.mean(np.concatenate(d2))))


def _sequences_case(rng: np.random.Generator) -> tuple:
    """(u (N, m), y (N, 3) m, seq_ids (N,), fit): 3-6 sequences of 6-40 rows, each with its own state."""
    n_seq, m = int(rng.integers(3, 7)), int(rng.integers(2, 7))
    sizes = rng.integers(6, 41, n_seq)
    seq_ids = np.repeat(np.arange(n_seq), sizes)
    u = rng.uniform(-0.6, 0.6, (len(seq_ids), m))
    state = rng.normal(0.0, 0.01, (n_seq, 3))[seq_ids]  # where each sequence started: not in u
    y = 0.3 + u @ rng.normal(0.0, 0.05, (m, 3)) + 0.02 * np.sin(3 * u[:, :1]) + state
    return u, y + 0.001 * rng.normal(size=y.shape), seq_ids, fit_linear


def check_held_out_sequences(student, *, case: int | None = None, show: bool = True) -> Grade:
    """Exercise 10.2: ``student(u, y, seq_ids, fit)`` -> the RMS 3-D distance (m) over all rows,
    each predicted by the model fitted without its sequence, against scikit-learn's
    ``LeaveOneGroupOut`` splits on 6 random data sets (2-6 motors, 3-6 sequences)."""
    rng = np.random.default_rng(102)
    return grade(
        "error on held-out sequences",
        student,
        _held_out_by_sklearn,
        [_sequences_case(rng) for _ in range(6)],
        show=show,
        case=case,
        checker=check_held_out_sequences,
        hint="a row may be predicted only by a model that never saw any row of its sequence; "
        "pool every held-out row's squared 3-D distance before the mean and the root",
    )


def check_history_features(student, *, case: int | None = None, show: bool = True) -> Grade:
    """Exercise 10.3: ``student(u, seq_ids, k)`` -> (N, m (k+1)) columns [u_t, ..., u_{t-k}]
    within each sequence, against :func:`history_features` on 6 random cases (1-5 sequences,
    1-6 motors, k = 0-3)."""
    rng = np.random.default_rng(103)
    cases = []
    for _ in range(6):
        n_rows, n_u, k_h = int(rng.integers(3, 40)), int(rng.integers(1, 7)), int(rng.integers(0, 4))
        seq_c = np.sort(rng.integers(0, int(rng.integers(1, 6)), n_rows))
        cases.append((rng.normal(size=(n_rows, n_u)), seq_c, k_h))
    return grade(
        "history features",
        student,
        history_features,
        cases,
        show=show,
        case=case,
        checker=check_history_features,
        hint="for each row, find where its sequence started; a step back never goes past that row",
    )
