"""Small helpers shared by several test modules (imported as ``from helpers import ...``;
pytest puts tests/ on sys.path)."""

import os
import time

import numpy as np


def wait_until(predicate, timeout_s=5.0, what="condition"):
    """Poll ``predicate()`` every 10 ms; AssertionError naming ``what`` after ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while not predicate():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")
        time.sleep(0.01)


def wait_on_rig(rig, predicate, timeout_s=10.0, what="condition", step_s=0.05):
    """Let time pass on the rig clock (reading frames, ``step_s`` at a time) until
    ``predicate()``; AssertionError naming ``what`` after ``timeout_s`` s of rig time. On a
    bench on virtual time this is the same run whatever the machine's load."""
    t_end = rig.now() + timeout_s
    while not predicate():
        if rig.now() > t_end:
            raise AssertionError(f"timed out after {timeout_s} s of rig time waiting for {what}")
        rig.wait(step_s)


def fd_jacobian(f, x, h=1e-6):
    """Central differences ``(f(x + h e_j) - f(x - h e_j)) / 2h`` for every unit vector e_j of
    the *last* axis of ``x``: shape ``f(x).shape + (n,)``, so ``J[..., i, j] = d f_i / d x_j``.

    The one finite-difference helper of the test suite: every analytic derivative (energy,
    cables, sensitivities, network and IK Jacobians) is checked against it. Leading axes
    of ``x`` are a batch: all rows move together, which gives the per-row Jacobians of a
    row-wise function (a batched network). ``x`` itself is never modified."""
    x = np.asarray(x, dtype=float)
    cols = []
    for j in range(x.shape[-1]):
        d = np.zeros(x.shape[-1])
        d[j] = h
        cols.append((np.asarray(f(x + d), dtype=float) - np.asarray(f(x - d), dtype=float)) / (2 * h))
    return np.stack(cols, axis=-1)


def fd_derivative(f, x, h=1e-6):
    """Central differences of an elementwise function: ``(f(x + h) - f(x - h)) / 2h``."""
    x = np.asarray(x, dtype=float)
    return (np.asarray(f(x + h), dtype=float) - np.asarray(f(x - h), dtype=float)) / (2 * h)


def fd_parameter_jacobian(model, u, h=1e-6):
    """Central-difference d y / d theta (N * n_y, n_params) of an MLP, parameters restored."""
    theta = model.get_params()

    def predict(th):
        model.set_params(th)
        return model.predict(u).ravel()

    try:
        return fd_jacobian(predict, theta, h)
    finally:
        model.set_params(theta)


def subprocess_env() -> dict:
    """The environment for a ``python -m lab`` subprocess: this one, one BLAS thread, no PYTHONPATH."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env.update(OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
    return env


#: Time limits that turn a hang into a named failure. A notebook cell gets CELL_TIMEOUT_S
#: (papermill's execution_timeout: the error names the cell); a whole chapter's test gets
#: NOTEBOOK_TEST_TIMEOUT_S (pytest-timeout, names the test). Every other test has pytest.ini's
#: ``timeout``. The slowest quick-mode cell takes about a minute on an idle 2-core machine, a
#: whole quick chapter about 1.5 min; the limits leave 5-10x for a loaded machine.
CELL_TIMEOUT_S = 600
NOTEBOOK_TEST_TIMEOUT_S = 1800


def execute_notebook(notebook, out, **kwargs):
    """papermill.execute_notebook with the per-cell limit and no progress bar."""
    import papermill

    kwargs.setdefault("execution_timeout", CELL_TIMEOUT_S)
    kwargs.setdefault("progress_bar", False)
    return papermill.execute_notebook(str(notebook), str(out), **kwargs)
