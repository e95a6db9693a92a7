"""Levenberg-Marquardt for large datasets: the curvature of a random sample of rows each epoch.

:func:`train_lm_subsample` is :func:`lab.learn.lm.train_lm` (``trainlm``'s damping schedule,
stop checks in MATLAB's order, validation failures, the best-validation network returned) with
one change: the Gauss-Newton matrix J^T J of each epoch comes from ``rows`` training rows
drawn at random (a fresh draw every epoch; products in float32, :data:`SINGLE`), scaled to
the whole set, while the error, the gradient J^T e (backpropagation, as
:meth:`lab.learn.mlp.MLP.gradient`) and every trial step's acceptance use all of them: a
sub-sampled Gauss-Newton method (Byrd, Chin, Neveitt and Nocedal 2011). An epoch then costs
about ``rows`` n_y n_params^2 multiply-adds for the curvature plus a few passes over the
data, instead of N n_y n_params^2; with ``rows`` >= N it is LM's step exactly (in float64).
``rows`` defaults to the most whose J^T J stays within
:data:`lab.learn.algorithm_choice.LM_WORK_LIMIT`, so an epoch's curvature costs what a
whole LM epoch costs on a dataset at the limit. Design notes: docs/design/learn.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lab.errors import InputError
from lab.learn.algorithm_choice import LM_WORK_LIMIT, blas_threads
from lab.learn.gauss_newton import gauss_newton
from lab.learn.lm import LMOptions, TrainLog, _arrays, _checked, _train_lm
from lab.learn.mlp import MLP, _slope
from lab.learn.training_data import TrainingData

__all__ = ["LMSubsampleOptions", "curvature_rows", "train_lm_subsample"]

#: A sample's J^T J in float32 (:func:`lab.learn.gauss_newton.gauss_newton`'s ``single``):
#: its rounding (about 1e-6 relative) is far below the sampling's own error.
SINGLE = True


@dataclass(frozen=True)
class LMSubsampleOptions(LMOptions):
    """``trainlm``'s parameters (:class:`lab.learn.lm.LMOptions`) and the rows of the curvature,
    with two defaults of their own: ``max_fail`` 20, as the gradient methods' (steps from a
    sampled curvature make the validation error noisier from epoch to epoch than LM's), and
    no gradient stop: on large datasets the paper's ``min_grad`` 1e-6 stops a run that is
    still improving (benchmarks/bench_training.txt, section C), and the validation set
    guards against over-fitting instead.

    Parameters
    ----------
    epochs, mu, mu_dec, mu_inc, mu_max, goal, max_jacobian_mb, dense_reference
        As :class:`lab.learn.lm.LMOptions` (``dense_reference`` is not used: the sample's
        J^T J is always formed by :func:`lab.learn.gauss_newton.gauss_newton`).
    max_fail : int
        Consecutive epochs of worse validation error that stop training.
    min_grad : float
        Gradient norm ``2 |J^T e| / N_e`` at or below which training stops (0: never).
    rows : int, optional
        Training rows drawn each epoch for J^T J (None: :func:`curvature_rows`).
    """

    max_fail: int = 20
    min_grad: float = 0.0
    rows: int | None = None

    def __post_init__(self):
        super().__post_init__()
        if self.rows is not None and (isinstance(self.rows, bool) or not isinstance(self.rows, int) or self.rows < 1):
            raise InputError(f"LMSubsampleOptions.rows must be a positive integer or None, got {self.rows!r}")


def curvature_rows(layer_sizes, n_train: int) -> int:
    """The default sample: the most rows whose J^T J (rows n_y n_params^2 multiply-adds)
    stays within :data:`lab.learn.algorithm_choice.LM_WORK_LIMIT`, at least 2 n_params
    (at most ``n_train``).

    Parameters
    ----------
    layer_sizes : sequence of int
        (n_u, hidden..., n_y).
    n_train : int
        Training rows.

    Returns
    -------
    int
        Rows per epoch.
    """
    sizes = [int(s) for s in layer_sizes]
    n_p = sum((a + 1) * b for a, b in zip(sizes[:-1], sizes[1:]))
    rows = int(LM_WORK_LIMIT // (sizes[-1] * n_p * n_p))
    return int(min(max(rows, 2 * n_p), n_train))


def _error_and_gradient(net, u, y):
    """e = y(u) - y (N, n_y) and J^T e by backpropagation, from one forward pass
    (:meth:`lab.learn.mlp.MLP.gradient` without its own)."""
    acts, y_n = net._forward(u)
    e = net._denormalise(y_n) - y
    delta = e / net.y_gain  # sum_k e_k dy_k / dy_n, dy / dy_n = 1 / g
    grads = []
    for l in range(len(net.weights) - 1, -1, -1):
        grads.append(np.concatenate([(delta.T @ acts[l]).ravel(), delta.sum(axis=0)]))
        if l:
            delta = (delta @ net.weights[l]) * _slope(net.activation, acts[l])
    return e, np.concatenate(grads[::-1])


def _products(net, u, y, rows, rng, max_mb, work):
    """MSE and J^T e / N_e on all rows; ("primal", J^T J / N_e) from ``rows`` of them."""
    n, n_e = len(u), y.size
    e, JE = _error_and_gradient(net, u, y)
    JE /= n_e
    pick = np.sort(rng.choice(n, rows, replace=False)) if rows < n else slice(None)
    _, _, JJ = gauss_newton(net, u[pick], y[pick], max_mb, single=SINGLE and rows < n, work=work)  # all: LM's
    JJ /= min(rows, n) * y.shape[1]  # the sample's mean curvature stands for the set's
    return float(np.vdot(e, e)) / n_e, JE, ("primal", JJ)


def train_lm_subsample(
    model: MLP,
    data: TrainingData,
    options: LMSubsampleOptions | None = None,
    *,
    seed: int | np.random.Generator = 0,
    progress=None,
) -> tuple[MLP, TrainLog]:
    """Levenberg-Marquardt with each epoch's curvature from a random sample of rows.

    Parameters
    ----------
    model : MLP
        The initial network (not changed; a copy is trained).
    data : TrainingData
        Training set (N, n_u) -> (N, n_y) in the model's units (rad -> m); the validation
        set stops training after ``max_fail`` worse epochs, the test set is only recorded.
    options : LMSubsampleOptions, optional
        Default ``LMSubsampleOptions()``.
    seed : int or numpy.random.Generator
        The stream that draws each epoch's rows.
    progress : callable, optional
        ``progress(epoch, history_row)``, called once per epoch.

    Returns
    -------
    MLP
        The best network seen (lowest validation MSE, or training MSE without validation).
    TrainLog
        Per epoch ``epoch``, ``perf``, ``vperf``, ``tperf`` (MSE, m^2), ``mu``, ``gradient``
        and ``val_fail``, as :func:`lab.learn.lm.train_lm`; ``options`` records ``rows``.
    """
    opt = _checked(options, LMSubsampleOptions)
    _arrays(data)
    rows = opt.rows if opt.rows is not None else curvature_rows(model.layer_sizes, len(data.u_train))
    rows = min(int(rows), len(data.u_train))
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    u, y, mb = data.u_train, data.y_train, opt.max_jacobian_mb
    work = {}  # gauss_newton's arrays, kept across epochs
    products = lambda net: _products(net, u, y, rows, rng, mb, work)  # noqa: E731
    with blas_threads(rows * model.n_y, model.n_params):
        net, log = _train_lm(model, data, opt, progress, products, "lm-subsample")
    log.options["rows"] = rows
    return net, log
