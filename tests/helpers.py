"""Small helpers shared by several test modules (imported as ``from helpers import ...``;
pytest puts tests/ on sys.path)."""
import time

import numpy as np


def wait_until(predicate, timeout_s=5.0, what="condition"):
    """Poll ``predicate()`` every 10 ms; AssertionError naming ``what`` after ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while not predicate():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")
        time.sleep(0.01)


def fd_parameter_jacobian(model, u, h=1e-6):
    """Central-difference d y / d theta (N * n_y, n_params) of an MLP, parameters restored."""
    theta, cols = model.get_params(), []
    for i in range(len(theta)):
        d = np.zeros_like(theta)
        d[i] = h
        model.set_params(theta + d)
        y_plus = model.predict(u)
        model.set_params(theta - d)
        cols.append(((y_plus - model.predict(u)) / (2 * h)).ravel())
    model.set_params(theta)
    return np.stack(cols, axis=1)
