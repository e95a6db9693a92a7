"""Frozen motors (the six-cable arm without its second stage) and motor-path smoothness."""

import numpy as np
import pytest
from helpers import fd_jacobian

from lab.control.command_set import CommandSet
from lab.control.ik import IKConfig, IKSolver
from lab.control.redundancy import FrozenMotors, frozen_commands, motor_path_stats
from lab.description import load_robot
from lab.learn.mlp_init import init_mlp

FREE = [0, 2, 4]


@pytest.fixture(scope="module")
def six_net():
    """A random 6-10-10-3 network: any smooth map with six inputs will do."""
    rng = np.random.default_rng(3)
    u = rng.uniform(0, 3, (50, 6))
    return init_mlp(u, 0.05 * np.tanh(u @ rng.normal(size=(6, 3))), (10, 10), seed=1)


@pytest.fixture(scope="module")
def six_commands():
    return CommandSet.from_robot(load_robot("six-cable"))


def test_frozen_map_is_the_full_map_with_fixed_motors(six_net):
    u_frozen = np.array([9.0, 0.7, 9.0, 1.3, 9.0, 0.2])  # entries at free indices are ignored
    fm = FrozenMotors(six_net, FREE, u_frozen)
    u_free = np.array([[0.5, 1.0, 2.0], [2.5, 0.1, 0.3]])
    full = fm.full(u_free)
    np.testing.assert_array_equal(full[:, [1, 3, 5]], [[0.7, 1.3, 0.2]] * 2)
    np.testing.assert_array_equal(full[:, FREE], u_free)
    np.testing.assert_allclose(fm.predict(u_free), six_net.predict(full))
    y, J = fm.predict_and_jacobian(u_free[0])
    assert J.shape == (3, 3)
    h = 1e-6
    J_fd = fd_jacobian(fm.predict, u_free[0], h)
    np.testing.assert_allclose(J, J_fd, rtol=1e-6, atol=1e-10)
    np.testing.assert_allclose(y, six_net.predict(full[0]))


@pytest.mark.parametrize("bad", [[0, 0, 1], [0, 6], [], [-1]])
def test_frozen_map_rejects_bad_motor_lists(six_net, bad):
    with pytest.raises(ValueError, match="free motors"):
        FrozenMotors(six_net, bad, np.zeros(6))


def test_frozen_commands_are_the_slice_of_the_allowed_set(six_commands):
    u_frozen = np.array([0.0, 3.0, 0.0, 3.0, 0.0, 2.0])  # 8 rad of the 14.25 rad budget used
    cs = frozen_commands(six_commands, FREE, u_frozen)
    assert cs.n == 3 and cs.b[0] == pytest.approx(six_commands.b[0] - 8.0)
    rng = np.random.default_rng(0)
    for u_free in rng.uniform(-0.5, 3.5, (400, 3)):
        full = u_frozen.copy()
        full[FREE] = u_free
        assert cs.contains(u_free, 0.0) == six_commands.contains(full, 0.0)
    with pytest.raises(ValueError, match="outside the motor limits"):
        frozen_commands(six_commands, FREE, [0, 3.5, 0, 0, 0, 0])


def test_motor_path_stats():
    u = np.array([[0.0, 0.0], [0.1, -0.2], [0.1, 0.3], [0.2, 0.3]])
    s = motor_path_stats(u)
    assert s["max_step_rad"] == pytest.approx(0.5) and s["max_step_index"] == 2
    assert s["travel_rad"] == pytest.approx(0.1 + 0.2 + 0.5 + 0.1)
    assert s["mean_step_rad"] == pytest.approx((0.2 + 0.5 + 0.1) / 3)
    with pytest.raises(ValueError, match="u_path"):
        motor_path_stats(u[:1])


def test_frozen_arm_misses_a_target_the_full_arm_reaches(six_net, six_commands):
    # A target made with every motor moving is reachable with all six; with three of
    # them frozen at 0 the tip can only move on a 3-parameter family that generally misses it.
    u_star = np.array([2.0, 1.5, 0.5, 2.5, 1.0, 2.2])
    target = six_net.predict(u_star)
    full = IKSolver(six_net, six_commands, IKConfig("lm")).solve(target, u0=np.full(6, 1.0))
    assert full.reachable
    frozen = FrozenMotors(six_net, FREE, np.zeros(6))
    part_commands = frozen_commands(six_commands, FREE, np.zeros(6))
    part = IKSolver(frozen, part_commands, IKConfig("lm")).solve(target, u0=np.ones(3))
    assert part.u_motor.shape == (3,)
    assert np.allclose(part.p_pred_W, six_net.predict(frozen.full(part.u_motor)))
    assert part.residual_m > 100 * full.residual_m


def _small_circle(net, u_centre, n=12, radius_rad=0.3):
    """Tips along a loop of commands about u_centre: reachable by construction."""
    t = 2 * np.pi * np.arange(n) / n
    phase = np.arange(6) * np.pi / 3
    return net.predict(u_centre + radius_rad * np.cos(t[:, None] + phase))


def test_follow_polishes_away_the_regulariser_bias(six_net, six_commands):
    targets = _small_circle(six_net, np.full(6, 1.5))
    kw = dict(reg_weight=1e-5, posture_weight=1e-5, u_posture=np.full(6, 1.0))
    biased = IKSolver(six_net, six_commands, IKConfig(polish=False, **kw)).follow(targets, u0=np.full(6, 1.5))
    exact = IKSolver(six_net, six_commands, IKConfig(**kw)).follow(targets, u0=np.full(6, 1.5))
    assert biased.residual_m.min() > 1e-5  # the regulariser alone pulls the tip off
    assert exact.reachable.all() and exact.residual_m.max() < 1e-8
    assert all(r.iterations > b.iterations for r, b in zip(exact.results, biased.results))


def test_posture_term_pulls_the_redundant_solution_towards_the_posture(six_net, six_commands):
    targets = _small_circle(six_net, np.full(6, 1.5))
    u_posture = np.array([0.5, 2.5, 0.5, 2.5, 0.5, 2.5])
    dist = {}
    for wp in (0.0, 1e-6):
        tr = IKSolver(six_net, six_commands, IKConfig(reg_weight=1e-6, posture_weight=wp, u_posture=u_posture)).follow(
            targets, u0=np.full(6, 1.5)
        )
        assert tr.reachable.all()
        dist[wp] = np.linalg.norm(tr.u_motor - u_posture, axis=1).mean()
    assert dist[1e-6] < 0.9 * dist[0.0], dist


@pytest.mark.parametrize(
    "kw, match",
    [
        ({"posture_weight": -1.0}, "posture.weight"),
        ({"posture_weight": np.nan}, "posture.weight"),
        ({"u_posture": np.full(6, 3.0)}, "u_posture"),
        ({"u_posture": np.ones(3)}, "u_posture"),
    ],
)
def test_bad_posture_settings_raise(six_net, six_commands, kw, match):
    with pytest.raises(ValueError, match=match):
        IKSolver(six_net, six_commands, IKConfig(**kw))
