"""lab.learn.bayes: Bayesian regularisation (trainbr) -- the step, the evidence, the effect."""

import numpy as np
import pytest

from lab.learn.bayes import BROptions, _step, _systems, effective_parameters, train_br
from lab.learn.lm import LMOptions, train_lm
from lab.learn.mlp_init import init_mlp
from lab.learn.train import train
from lab.learn.training_data import TrainingData


def noisy_problem(n, noise, seed):
    rng = np.random.default_rng(seed)
    u = rng.uniform(0, 3, (n, 2))
    y = np.c_[np.sin(u[:, 0]) * np.cos(u[:, 1]), u[:, 0] * u[:, 1] / 9]
    return u, y, y + noise * rng.standard_normal(y.shape)


@pytest.mark.parametrize("hidden,n", [((4,), 40), ((12, 12), 30)])  # primal (n_p < N_e) and kernel form
def test_step_and_gamma_against_the_dense_formulas(hidden, n):
    u, _, y = noisy_problem(n, 0.05, 1)
    net = init_mlp(u, y, hidden, seed=3)
    theta, n_e = net.get_params(), y.size
    perf, JE, system = _systems(net, u, y, 256.0)
    assert system[0] == ("primal" if net.n_params < n_e else "kernel")
    y_hat, J = net.parameter_jacobian(u)
    e = (y_hat - y).ravel()
    ratio, mu = 0.37, 2e-3
    # minimiser of |e + J d|^2 + ratio |theta + d|^2 + mu N_e |d|^2
    A = J.T @ J + (ratio + mu * n_e) * np.eye(net.n_params)
    d_ref = -np.linalg.solve(A, J.T @ e + ratio * theta)
    d = _step(system, JE, theta, ratio, mu, n_e, np.empty_like(system[1], order="F"))
    np.testing.assert_allclose(d, d_ref, rtol=1e-8, atol=1e-12 * np.abs(d_ref).max())
    # MacKay: gamma = n_params - ratio * trace((J^T J + ratio I)^-1)
    gamma_ref = net.n_params - ratio * np.trace(np.linalg.inv(J.T @ J + ratio * np.eye(net.n_params)))
    assert effective_parameters(system, ratio) == pytest.approx(gamma_ref, rel=1e-8)


def test_br_beats_unregularised_lm_on_small_noisy_data_and_estimates_the_noise():
    noise = 0.05
    u, y_clean, y = noisy_problem(60, noise, 0)
    u_test, y_test_clean, _ = noisy_problem(400, noise, 9)
    net = init_mlp(u, y, (10, 10), seed=1)  # 162 parameters for 120 residuals: LM interpolates the noise
    lm, _ = train_lm(net, TrainingData(u, y), LMOptions(epochs=300, min_grad=0))
    br, log = train_br(net, TrainingData(u, y), BROptions(epochs=300))
    err = lambda m: np.mean(np.linalg.norm(m.predict(u_test) - y_test_clean, axis=1))  # noqa: E731
    assert err(br) < 0.6 * err(lm)
    gamma = log.history["gamma"][-1]
    assert 5 < gamma < 0.5 * net.n_params  # far fewer effective parameters than weights
    beta = log.history["beta"][-1]
    assert 1 / np.sqrt(2 * beta) == pytest.approx(noise, rel=0.3)  # beta = 1 / (2 sigma^2)
    alpha, ssw = log.history["alpha"][-1], log.history["ssw"][-1]
    assert log.algorithm == "br" and np.isfinite(alpha) and alpha > 0 and ssw > 0
    # unregularised LM fits the noise: its training error is far below the noise level
    assert np.sqrt(np.mean((lm.predict(u) - y) ** 2)) < 0.5 * noise


def test_train_br_records_the_hyperparameters():
    u, _, y = noisy_problem(50, 0.02, 2)
    res = train(u, y, (6,), algorithm="br", ratios=(1, 0, 0), seed=0, epochs=40)
    reg = res.model.metadata["training"]["bayesian_regularisation"]
    assert set(reg) == {"alpha", "beta", "gamma", "n_params", "noise_std_m", "sum_squared_weights"}
    assert reg["n_params"] == res.model.n_params == 6 * 2 + 6 + 6 * 2 + 2
    assert 0 < reg["gamma"] < reg["n_params"]
    assert reg["gamma"] == res.log.history["gamma"][-1] and reg["alpha"] > 0 and reg["beta"] > 0
    assert res.model.metadata["training"]["algorithm"] == "br"
    assert res.model.metadata["training"]["options"]["mu"] == 0.005  # trainbr's default
