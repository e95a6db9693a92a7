"""Which trainer suits a network and a dataset, by size: Levenberg-Marquardt where it is cheap.

An epoch of Levenberg-Marquardt or Bayesian regularisation (:mod:`lab.learn.lm`,
:mod:`lab.learn.bayes`) forms J^T J, about N_e n_params^2 multiply-adds (N_e = training rows
x outputs), and solves n_params x n_params systems: right for the few hundred rows of a
robot's grid, wrong for tens of thousands, where one epoch takes seconds and a run of 1000
epochs hours. :func:`choose_algorithm` is what ``--algorithm auto`` (the default of
``train`` and ``splits``) runs: ``lm`` while :func:`lm_work` stays within
:data:`LM_WORK_LIMIT`, else ``lm-subsample`` (:mod:`lab.learn.lm_subsample`: the same
steps, with each epoch's J^T J from as many random rows as the limit allows). Adam and
L-BFGS reach errors several times LM's on such data (``benchmarks/bench_training.py``, which
measures the limit too).

Small systems also run on one BLAS thread (:func:`blas_threads`): with matrices of a few
hundred rows the threads' start-up and spinning cost more than they save, many times more on
a machine whose cores are busy."""

from __future__ import annotations

import contextlib

__all__ = ["LM_WORK_LIMIT", "LARGE_DATA_ALGORITHM", "lm_work", "choose_algorithm", "blas_threads"]

#: N_e n_params^2 (multiply-adds of one epoch's J^T J) up to which ``auto`` trains by LM.
LM_WORK_LIMIT = 2e9

#: What ``auto`` trains with above :data:`LM_WORK_LIMIT`.
LARGE_DATA_ALGORITHM = "lm-subsample"


def _n_params(sizes) -> int:
    return sum((a + 1) * b for a, b in zip(sizes[:-1], sizes[1:]))


def lm_work(layer_sizes, n_train: int) -> float:
    """Multiply-adds of one epoch's J^T J: N_e n_params^2, N_e = ``n_train`` x outputs.

    Parameters
    ----------
    layer_sizes : sequence of int
        (n_u, hidden..., n_y).
    n_train : int
        Training samples.

    Returns
    -------
    float
        N_e n_params^2.
    """
    sizes = [int(s) for s in layer_sizes]
    return float(n_train) * sizes[-1] * float(_n_params(sizes)) ** 2


def choose_algorithm(layer_sizes, n_train: int) -> tuple[str, str]:
    """The trainer ``--algorithm auto`` picks for this network and training set, and why.

    Parameters
    ----------
    layer_sizes : sequence of int
        (n_u, hidden..., n_y).
    n_train : int
        Training samples.

    Returns
    -------
    algorithm : str
        ``"lm"`` or :data:`LARGE_DATA_ALGORITHM`.
    reason : str
        The words a run's summary line gives, e.g. "auto: 831 residuals x 563^2 parameters
        = 2.6e+08 <= 2e+09" (the multiply-adds of LM's J^T J per epoch, and the limit).
    """
    sizes = [int(s) for s in layer_sizes]
    work = lm_work(sizes, n_train)
    n_e, n_p = int(n_train) * sizes[-1], _n_params(sizes)
    small = work <= LM_WORK_LIMIT
    words = f"auto: {n_e:,} residuals x {n_p:,}^2 parameters = {work:.2g} {'<=' if small else '>'} {LM_WORK_LIMIT:.0g}"
    return ("lm" if small else LARGE_DATA_ALGORITHM), words


def blas_threads(n_e: int, n_params: int):
    """A context in which BLAS runs one thread when LM's epoch is small (within
    :data:`LM_WORK_LIMIT`), else a context that changes nothing; nothing either without
    ``threadpoolctl``.

    Parameters
    ----------
    n_e : int
        Residuals: training rows x outputs.
    n_params : int
        The network's parameters.

    Returns
    -------
    contextlib.AbstractContextManager
        The context.
    """
    if float(n_e) * float(n_params) ** 2 > LM_WORK_LIMIT:
        return contextlib.nullcontext()
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - installed with scikit-learn
        return contextlib.nullcontext()
    return threadpool_limits(limits=1, user_api="blas")
