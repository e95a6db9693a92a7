"""The shared finite-difference helper against known derivatives."""

import numpy as np
from helpers import fd_derivative, fd_jacobian


def test_fd_jacobian_of_a_vector_function():
    A = np.array([[1.0, 2.0, -1.0], [0.5, 0.0, 3.0]])
    x = np.array([0.3, -0.2, 0.7])
    keep = x.copy()
    f = lambda z: A @ z + np.sin(z[0]) * np.array([1.0, 0.0])  # noqa: E731
    J = fd_jacobian(f, x, 1e-6)
    exact = A.copy()
    exact[0, 0] += np.cos(x[0])
    assert J.shape == (2, 3) and np.allclose(J, exact, atol=1e-9)
    assert np.array_equal(x, keep)


def test_fd_jacobian_of_a_scalar_and_of_a_batch():
    x = np.array([1.0, 2.0])
    assert np.allclose(fd_jacobian(lambda z: z @ z, x), 2 * x, atol=1e-8)
    X = np.array([[1.0, 2.0], [3.0, -1.0]])  # rows are a batch of a row-wise function
    J = fd_jacobian(lambda Z: np.stack([Z[:, 0] * Z[:, 1], Z[:, 0] ** 2], axis=-1), X, 1e-6)
    exact = np.array([[[X[i, 1], X[i, 0]], [2 * X[i, 0], 0.0]] for i in range(2)])
    assert J.shape == (2, 2, 2) and np.allclose(J, exact, atol=1e-8)


def test_fd_derivative_is_elementwise():
    x = np.linspace(0.0, 1.0, 5)
    assert np.allclose(fd_derivative(np.exp, x, 1e-6), np.exp(x), atol=1e-8)
