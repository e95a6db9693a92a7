"""Chapters 3 and 4's graders (lab.course.ch03, lab.course.ch04) pass a right answer and
catch the wrong ones a student is likely to write.

Each grader is run without showing its result (``grade`` prints outside IPython; the
output is captured): a correct implementation, written independently of ``lab``'s, must
pass, and each wrong variant must fail. Exercise 3.3's cases must contain failed trial
steps, or a loop without the retry rule would pass.
"""

from pathlib import Path

import numpy as np
import pytest
from helpers import assert_reruns

from lab.course.ch03 import check_lm_step, check_lm_training, check_network_jacobian, lm_training_cases
from lab.course.ch04 import check_gd_step, check_projection, check_tracking_error
from lab.learn import LMOptions, TrainingData, lm_step, load_model, mse, train_lm

ROOT = Path(__file__).resolve().parent.parent


def _jacobian(net, u):
    a = net.u_gain * (u - net.u_min) - 1.0
    J = np.diag(net.u_gain)
    for W, b in zip(net.weights[:-1], net.biases[:-1]):
        z = W @ a + b
        a = np.tanh(z) if net.activation == "tanh" else 1 / (1 + np.exp(-z))
        J = np.diag(1 - a**2 if net.activation == "tanh" else a * (1 - a)) @ W @ J
    return np.diag(1 / net.y_gain) @ net.weights[-1] @ J


def _lm_step(net, u, y, mu):
    y_hat, J = net.parameter_jacobian(u)
    e = (y_hat - y).ravel()
    return np.linalg.solve(J.T @ J / e.size + mu * np.eye(J.shape[1]), -J.T @ e / e.size)


def _loop(step, retry=True, grow=10.0, shrink=0.1, check=True):
    """trainlm's loop with ``step`` for the trial step; the keywords make it wrong."""

    def train(net, u, y, epochs):
        theta, mu = net.get_params(), 1e-3
        perf = mse(net, u, y)
        for _ in range(epochs):
            for _ in range(40 if retry else 1):
                net.set_params(theta)
                trial = theta + step(net, u, y, mu)
                net.set_params(trial)
                if not check or mse(net, u, y) < perf:
                    theta, perf, mu = trial, mse(net, u, y), mu * shrink
                    break
                mu *= grow
        return theta

    return train


def test_chapter_3_graders_pass_right_and_catch_wrong_answers():
    assert check_network_jacobian(_jacobian, show=False).status == "passed"
    without_g_y = lambda net, u: net.y_gain[:, None] * _jacobian(net, u)  # noqa: E731
    without_g_u = lambda net, u: _jacobian(net, u) / net.u_gain  # noqa: E731
    for wrong in (without_g_y, without_g_u, lambda net, u: _jacobian(net, u).T):
        assert check_network_jacobian(wrong, show=False).status == "failed"
    assert_reruns(
        check_network_jacobian(wrong, show=False), lambda k: check_network_jacobian(wrong, case=k, show=False)
    )
    assert check_lm_step(_lm_step, show=False).status == "passed"
    assert check_lm_step(lambda *a: -_lm_step(*a), show=False).status == "failed"  # uphill
    wrong = lambda net, u, y, mu: _lm_step(net, u, y, mu * 3)  # noqa: E731
    assert_reruns(check_lm_step(wrong, show=False), lambda k: check_lm_step(wrong, case=k, show=False))
    assert check_lm_training(_loop(_lm_step), show=False).status == "passed"  # its own step: rounding only
    assert check_lm_training(_loop(lm_step), show=False).status == "passed"
    for wrong in (_loop(lm_step, retry=False), _loop(lm_step, grow=1.0, shrink=1.0), _loop(lm_step, check=False)):
        assert check_lm_training(wrong, show=False).status == "failed"
    wrong = _loop(lm_step, shrink=1.0)
    assert_reruns(check_lm_training(wrong, show=False), lambda k: check_lm_training(wrong, case=k, show=False))


def test_chapter_3_training_cases_have_failed_trial_steps():
    for net, u, y, epochs in lm_training_cases():
        _, log = train_lm(net, TrainingData(u, y), LMOptions(epochs=epochs, min_grad=0.0))
        mu = log.history["mu"]
        assert np.any(mu[1:] >= mu[:-1]), "no trial step failed: a loop without retries would pass"


def _project(v, u_max, sum_max):
    """Bisection on the common shift, written apart from lab's active-set method."""
    c = np.clip(v, 0.0, u_max)
    if c.sum() <= sum_max:
        return c
    lo, hi = 0.0, float(np.max(v))
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if np.clip(v - mid, 0.0, u_max).sum() > sum_max else (lo, mid)
    return np.clip(v - hi, 0.0, u_max)


def _scaled(v, u_max, sum_max):
    c = np.clip(v, 0.0, u_max)
    return c * min(1.0, sum_max / c.sum()) if c.sum() else c


def _shifted_once(v, u_max, sum_max):
    c = np.clip(v, 0.0, u_max)
    return np.clip(c - max(0.0, c.sum() - sum_max) / len(c), 0.0, u_max)


@pytest.mark.parametrize(
    "wrong",
    [
        lambda v, u_max, s: np.clip(v, 0.0, u_max),  # the box only
        _scaled,  # clip, then scale down
        _shifted_once,  # clip, shift once, clip
        lambda v, u_max, s: _project(np.clip(v, 0.0, u_max), u_max, s),  # shifts the clipped command
    ],
    ids=["clip", "clip-scale", "shift-once", "shift-clipped"],
)
def test_chapter_4_projection_grader_catches_wrong_projections(wrong):
    assert check_projection(_project, show=False).status == "passed"
    assert_reruns(check_projection(wrong, show=False), lambda k: check_projection(wrong, case=k, show=False))


def test_chapter_4_gd_step_and_tracking_graders():
    model = load_model(ROOT / "data" / "model_sim_three_cable.npz")

    def step(model, u, target, alpha, u_min, u_max):
        y, J = model.predict_and_jacobian(u)
        return np.clip(u - alpha * J.T @ (y - target), u_min, u_max)

    assert check_gd_step(step, model, 3.0, show=False).status == "passed"
    no_clip = lambda model, u, target, alpha, u_min, u_max: step(model, u, target, alpha, -9, 9)  # noqa: E731
    assert_reruns(
        check_gd_step(no_clip, model, 3.0, show=False), lambda k: check_gd_step(no_clip, model, 3.0, case=k, show=False)
    )

    def error_cm(targets_W, achieved_W):
        d = np.linalg.norm(achieved_W - targets_W, axis=1)
        return 100 * d.mean(), 100 * d.max()

    assert check_tracking_error(error_cm, show=False).status == "passed"
    per_axis = lambda t, a: (100 * np.abs(a - t).mean(), 100 * np.abs(a - t).max())  # noqa: E731
    assert_reruns(
        check_tracking_error(per_axis, show=False), lambda k: check_tracking_error(per_axis, case=k, show=False)
    )
