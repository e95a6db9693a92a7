"""lab.learn.gauss_newton: J^T J and J^T e from the layers' structure, against the dense
product, central differences and torch autograd; and the LM/BR trainers built on them give
the reference path's results to round-off."""

import numpy as np
import pytest
from helpers import fd_parameter_jacobian

from lab.learn.bayes import BROptions, _systems, effective_parameters, train_br
from lab.learn.gauss_newton import gauss_newton
from lab.learn.lm import LMOptions, _jacobian_products, train_lm
from lab.learn.mlp import MLP
from lab.learn.mlp_init import init_mlp
from lab.learn.training_data import TrainingData


def problem(n, n_u, n_y, seed=0):
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1, 2, (n, n_u))
    y = 0.1 * np.sin(u @ rng.standard_normal((n_u, n_y)))
    return u, y


def network(hidden, n_u, n_y, u, y, activation="tanh", seed=1):
    if not hidden:  # a linear network: the output layer alone
        rng = np.random.default_rng(seed)
        weights, biases = [rng.standard_normal((n_y, n_u))], [rng.standard_normal(n_y)]
        return MLP(weights, biases, u.min(0), u.max(0), y.min(0), y.max(0))
    net = init_mlp(u, y, hidden, activation, seed=seed)
    net.set_params(net.get_params() + 0.3 * np.random.default_rng(seed).standard_normal(net.n_params))
    return net


CASES = [((), 3, 2), ((5,), 2, 1), ((30,), 3, 3), ((4, 6), 3, 2), ((10, 10), 6, 3), ((4, 6, 5), 3, 2)]


@pytest.mark.parametrize("hidden, n_u, n_y", CASES)
@pytest.mark.parametrize("activation", ["tanh", "logistic"])
def test_products_equal_the_dense_jacobians_to_round_off(hidden, n_u, n_y, activation):
    u, y = problem(37, n_u, n_y)
    net = network(hidden, n_u, n_y, u, y, activation)
    y_hat, J = net.parameter_jacobian(u)
    e = (y_hat - y).ravel()
    for max_mb in (256.0, 1e-4):  # one chunk; one sample per chunk
        sse, JE, JJ = gauss_newton(net, u, y, max_mb)
        assert sse == pytest.approx(e @ e, rel=1e-13)
        np.testing.assert_allclose(JE, J.T @ e, rtol=1e-11, atol=1e-13 * np.abs(J.T @ e).max())
        ref = J.T @ J
        assert np.abs(np.triu(JJ) - np.triu(ref)).max() <= 1e-13 * np.abs(ref).max()
        assert not np.tril(JJ, -1).any() and JJ.flags.f_contiguous  # what the Cholesky reads


@pytest.mark.parametrize("hidden, n_u, n_y", [((6,), 3, 3), ((4, 5), 2, 2)])
def test_products_match_central_differences_and_torch_autograd(hidden, n_u, n_y):
    import torch

    u, y = problem(11, n_u, n_y, seed=4)
    net = network(hidden, n_u, n_y, u, y, seed=5)
    sse, JE, JJ = gauss_newton(net, u, y)
    e = (net.predict(u) - y).ravel()
    J_fd = fd_parameter_jacobian(net, u)
    scale = np.abs(J_fd.T @ J_fd).max()
    assert np.abs(np.triu(JJ) - np.triu(J_fd.T @ J_fd)).max() <= 1e-7 * scale
    assert np.abs(JE - J_fd.T @ e).max() <= 1e-7 * np.abs(JE).max()

    t = lambda a: torch.tensor(a, dtype=torch.float64)  # noqa: E731
    shapes = [(w.shape, b.shape) for w, b in zip(net.weights, net.biases)]

    def f(theta):  # y(u) of every sample as a function of theta, in the order of get_params
        a, k = (t(u) - t(net.u_min)) * t(net.u_gain) - 1.0, 0
        for l, (sw, sb) in enumerate(shapes):
            W = theta[k : k + sw[0] * sw[1]].reshape(sw)
            k += sw[0] * sw[1]
            b = theta[k : k + sb[0]]
            k += sb[0]
            a = a @ W.T + b
            a = torch.tanh(a) if l < len(shapes) - 1 else a
        return ((a + 1.0) / t(net.y_gain) + t(net.y_min)).reshape(-1)

    J_t = torch.autograd.functional.jacobian(f, t(net.get_params())).numpy()
    ref = J_t.T @ J_t
    assert np.abs(np.triu(JJ) - np.triu(ref)).max() <= 1e-12 * np.abs(ref).max()
    np.testing.assert_allclose(JE, J_t.T @ e, rtol=1e-10, atol=1e-13 * np.abs(JE).max())


@pytest.mark.parametrize("hidden, n", [((4,), 40), ((12, 12), 30)])  # primal and kernel form
def test_gamma_from_a_cholesky_factor_equals_the_eigenvalues(hidden, n):
    u, y = problem(n, 2, 2, seed=2)
    net = network(hidden, 2, 2, u, y)
    _, _, system = _systems(net, u, y, 256.0)
    for ratio in (1e-6, 0.37, 40.0):
        assert effective_parameters(system, ratio) == pytest.approx(effective_parameters(system, ratio, True), rel=1e-9)
    assert effective_parameters(system, 0.0) == effective_parameters(system, 0.0, True)  # the rank, by eigenvalues


def test_structured_products_keep_the_lm_system_of_the_reference():
    u, y = problem(50, 3, 3)
    net = network((8, 7), 3, 3, u, y)
    a, b = _jacobian_products(net, u, y, 256.0), _jacobian_products(net, u, y, 256.0, dense=True)
    assert a[0] == pytest.approx(b[0], rel=1e-13) and a[2][0] == b[2][0] == "primal"
    np.testing.assert_allclose(a[1], b[1], rtol=1e-11, atol=1e-14)
    assert np.abs(np.triu(a[2][1]) - np.triu(b[2][1])).max() <= 1e-13 * np.abs(b[2][1]).max()


@pytest.mark.parametrize("trainer, options", [(train_lm, LMOptions), (train_br, BROptions)])
def test_trainers_follow_the_reference_path_to_round_off(trainer, options):
    u, y = problem(60, 3, 3, seed=6)
    y = y + 0.002 * np.random.default_rng(7).standard_normal(y.shape)
    net = init_mlp(u, y, (9,), seed=3)  # 75 parameters < 180 residuals: the primal form
    data = TrainingData(u[:48], y[:48], u[48:], y[48:])
    fast, log = trainer(net, data, options(epochs=25, min_grad=0))
    ref, log_ref = trainer(net, data, options(epochs=25, min_grad=0, dense_reference=True))
    assert log.epochs == log_ref.epochs and log.stop_reason == log_ref.stop_reason
    np.testing.assert_array_equal(log.history["mu"], log_ref.history["mu"])  # the same accepted steps
    np.testing.assert_allclose(log.history["perf"], log_ref.history["perf"], rtol=1e-7)
    np.testing.assert_allclose(fast.get_params(), ref.get_params(), rtol=1e-6, atol=1e-9)
    assert log.options["dense_reference"] is False and log_ref.options["dense_reference"] is True


def test_dense_reference_must_be_a_bool():
    from lab.errors import InputError

    with pytest.raises(InputError, match="LMOptions.dense_reference"):
        LMOptions(dense_reference="yes")


@pytest.mark.parametrize("hidden", [(8,), (6, 7)])
def test_single_precision_products_stay_within_float32_rounding(hidden):
    u, y = problem(200, 3, 3, seed=8)
    net = network(hidden, 3, 3, u, y)
    sse, JE, JJ = gauss_newton(net, u, y)
    sse32, JE32, JJ32 = gauss_newton(net, u, y, single=True)
    assert JJ32.dtype == np.float64 and sse32 == sse
    np.testing.assert_allclose(JE32, JE, rtol=1e-12, atol=1e-15 * np.abs(JE).max())  # J^T e stays float64
    assert 0 < np.abs(JJ32 - JJ).max() <= 1e-5 * np.abs(JJ).max()
