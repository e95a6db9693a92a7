"""Inverse kinematics: exact projection onto the allowed commands, both solvers, edge cases, Soft IK."""

import itertools

import numpy as np
import pytest
from helpers import fd_jacobian

from lab.control.command_set import CommandSet
from lab.control.ik import IKConfig, IKSolver, grid_seeds
from lab.control.soft_ik import FEMForwardMap
from lab.control.trajectories import circle
from lab.data.dataset import read_dataset
from lab.description import load_robot
from lab.fem.solve.statics import solve_static


@pytest.fixture(scope="module")
def cset(three_cable):
    return CommandSet.from_robot(three_cable)


@pytest.fixture(scope="module")
def small_model():
    """A small network fitted to the simulated data in a fraction of a second."""
    from lab.learn.train import train

    u, y, _ = read_dataset("data/sim_three_cable.csv")
    return train(u, y, (10, 10), seed=0, epochs=40).model


def brute_force_qp(cs: CommandSet, H, c):
    """Reference: minimiser of 1/2 x'Hx + c'x over every face {G_S x = h_S} (S of up to m
    independent constraints) whose solution is feasible; the convex optimum is one of them."""
    best, best_val = None, np.inf
    m = cs.n
    for size in range(m + 1):
        for S in itertools.combinations(range(len(cs.h)), size):
            G = cs.G[list(S)]
            if size and np.linalg.matrix_rank(G) < size:
                continue
            K = np.block([[H, G.T], [G, np.zeros((size, size))]])
            x = np.linalg.solve(K, np.concatenate([-c, cs.h[list(S)]]))[:m]
            if np.all(cs.G @ x <= cs.h + 1e-10):
                val = 0.5 * x @ H @ x + c @ x
                if val < best_val - 1e-15:
                    best, best_val = x, val
    return best


def test_command_set_from_robot(three_cable, cset):
    assert cset.A.shape == (1, 3)
    assert cset.b[0] == pytest.approx(13 / 6 * three_cable.u_max_rad)
    assert cset.contains([3.0, 3.0, 0.5]) and not cset.contains([3.0, 3.0, 0.6])
    assert not cset.contains([-0.01, 0, 0]) and not cset.contains([np.nan, 0, 0])
    with pytest.raises(ValueError, match="lower corner"):
        CommandSet([0, 0], [1, 1], [[-1.0, 0.0]], [-0.5])


@pytest.mark.parametrize("extra_rows", [0, 2])
def test_projection_is_exact(cset, extra_rows):
    """Against the brute-force face enumeration, including points whose projection lies on
    the safety plane, a box face and both (edges, vertices)."""
    cs = cset
    if extra_rows:  # a four-motor set with several overlapping limits
        A = np.array([[1, 1, 1, 1], [1, 0, 0, 1], [0, 1, 1, 0.5]])
        cs = CommandSet(np.zeros(4), np.full(4, 3.0), A, [7.0, 4.0, 3.5])
    rng = np.random.default_rng(1)
    n_inside = 0
    for _ in range(60):
        v = rng.uniform(-2.0, 5.0, cs.n)
        p = cs.project(v)
        ref = brute_force_qp(cs, np.eye(cs.n), -v)
        np.testing.assert_allclose(p, ref, atol=1e-12)
        n_inside += cs.contains(v, 0.0)
    assert n_inside < 50  # most points needed a real projection


def test_qp_is_exact(cset):
    rng = np.random.default_rng(2)
    for _ in range(40):
        M = rng.standard_normal((3, 3))
        H = M @ M.T + 0.1 * np.eye(3)
        c = rng.normal(0.0, 10.0, 3)
        x = cset.solve_qp(H, c, x0=cset.project(rng.uniform(0, 3, 3)))
        np.testing.assert_allclose(x, brute_force_qp(cset, H, c), atol=1e-10)


def random_safe_commands(cset, n, seed):
    rng = np.random.default_rng(seed)
    u = rng.uniform(0, 3.0, (4 * n, 3))
    return u[np.all(u @ cset.A.T <= cset.b - 0.2, axis=1)][:n]


@pytest.mark.parametrize("method", ["lm", "gd"])
def test_converges_on_reachable_targets(small_model, cset, method):
    solver = IKSolver(small_model, cset, IKConfig(method, tol_m=1e-8), seeds=grid_seeds(small_model, cset, 5))
    for u_star in random_safe_commands(cset, 6 if method == "lm" else 3, seed=3):
        target = small_model.predict(u_star)
        res = solver.solve(target)
        assert res.status == "converged" and res.reachable, res
        assert res.residual_m <= 1e-8
        assert np.linalg.norm(small_model.predict(res.u_motor) - target) <= 1e-8
        assert cset.contains(res.u_motor)
    if method == "lm":
        assert res.iterations <= 20


def test_gd_and_lm_agree(small_model, cset):
    u_star = np.array([1.2, 0.4, 2.0])
    target = small_model.predict(u_star)
    a = IKSolver(small_model, cset, IKConfig("lm")).solve(target, u0=[1.0, 0.5, 1.8])
    b = IKSolver(small_model, cset, IKConfig("gd", tol_m=1e-9)).solve(target, u0=[1.0, 0.5, 1.8])
    np.testing.assert_allclose(a.u_motor, u_star, atol=1e-4)  # |du| ~ tol_m / sigma_min(J)
    np.testing.assert_allclose(b.u_motor, u_star, atol=1e-4)
    assert b.iterations > 5 * a.iterations  # why LM is the default


@pytest.mark.parametrize("method", ["lm", "gd"])
def test_unreachable_target_returns_best_allowed_command(small_model, cset, method):
    u_grid, y_grid = grid_seeds(small_model, cset, 13)
    solver = IKSolver(small_model, cset, IKConfig(method), seeds=(u_grid, y_grid))
    for target in ([0.30, 0.10, 0.20], [0.10, 0.0, -0.02], [0.17, 0.0, -0.007]):
        target = np.array(target)
        res = solver.solve(target)
        assert not res.reachable and res.status in ("stationary", "converged"), res
        assert np.all(np.isfinite(res.u_motor)) and cset.contains(res.u_motor)
        assert res.residual_m == pytest.approx(np.linalg.norm(small_model.predict(res.u_motor) - target))
        # no allowed command of a fine grid comes closer
        assert res.residual_m <= np.min(np.linalg.norm(y_grid - target, axis=1)) + 1e-9


def test_pulling_the_arm_short_stops_at_the_safety_limit(small_model, cset):
    """A target beyond the largest allowed contraction: the optimum lies on the safety plane."""
    res = IKSolver(small_model, cset, IKConfig("lm")).solve([0.15, 0.0, -0.007])
    assert not res.reachable
    assert res.u_motor.sum() == pytest.approx(cset.b[0], abs=1e-9)
    assert cset.contains(res.u_motor)


@pytest.mark.parametrize("bad", [[np.nan, 0, 0], [0.2, np.inf, 0.0], [[0.2, 0, 0], [0.2, 0, -np.inf]]])
def test_non_finite_targets_raise(small_model, cset, bad):
    solver = IKSolver(small_model, cset)
    with pytest.raises(ValueError, match="not finite"):
        solver.follow(bad) if np.ndim(bad) == 2 else solver.solve(bad)


def test_bad_arguments_raise(small_model, cset):
    with pytest.raises(ValueError, match="method"):
        IKSolver(small_model, cset, IKConfig("newton"))
    with pytest.raises(ValueError, match=r"\(3,\)"):
        IKSolver(small_model, cset).solve([0.2, 0.0])
    with pytest.raises(ValueError, match="u0"):
        IKSolver(small_model, cset).solve([0.2, 0, 0], u0=[1.0, 2.0])


def test_warm_starts_reduce_iterations(small_model, cset):
    targets = circle(200)[:40]  # 1.1 mm apart
    solver = IKSolver(small_model, cset, IKConfig("lm"))
    warm = solver.follow(targets)
    cold = [solver.solve(t) for t in targets]  # each from the centre of the command set
    assert warm.reachable.all() and all(r.reachable for r in cold)
    assert warm.iterations[1:].sum() < 0.8 * sum(r.iterations for r in cold[1:])
    assert warm.iterations[1:].max() <= 3


def test_regulariser_trades_residual_for_staying_close(small_model, cset):
    u_ref = np.array([1.0, 1.0, 1.0])
    target = small_model.predict(np.array([1.5, 0.5, 1.2]))
    dist, resid = [], []
    for w in (0.0, 1e-5, 1e-3):
        r = IKSolver(small_model, cset, IKConfig(reg_weight=w)).solve(target, u0=u_ref, u_ref=u_ref)
        dist.append(np.linalg.norm(r.u_motor - u_ref))
        resid.append(r.residual_m)
    assert resid[0] < 1e-8 < resid[1] < resid[2]
    assert dist[0] > dist[1] > dist[2]


class Flaky:
    """A forward map with no answer (NaN) where u0 > 1.5: the IK must step around it."""

    def __init__(self, model):
        self.model = model

    def predict_and_jacobian(self, u):
        if u[0] > 1.5:
            return np.full(3, np.nan), np.full((3, 3), np.nan)
        return self.model.predict_and_jacobian(u)


def test_failed_evaluations_are_rejected_steps(small_model, cset):
    target = small_model.predict(np.array([2.5, 0.5, 0.5]))  # lies in the "failed" region
    res = IKSolver(Flaky(small_model), cset).solve(target, u0=[1.0, 0.5, 0.5])
    assert np.all(np.isfinite(res.u_motor)) and res.u_motor[0] <= 1.5 and not res.reachable
    with pytest.raises(ValueError, match="no finite tip at the start"):
        IKSolver(Flaky(small_model), cset).solve(target, u0=[2.0, 0.5, 0.5])


def test_soft_ik_on_a_coarse_mesh(coarse_fem, cset):
    fmap = FEMForwardMap(coarse_fem)
    u0 = np.array([1.0, 0.4, 0.2])
    y0, J = fmap.predict_and_jacobian(u0)
    h = 1e-5
    J_fd = fd_jacobian(lambda v: solve_static(coarse_fem, v, tol_step_m=1e-11).p_tip_W, u0, h)
    np.testing.assert_allclose(J, J_fd, atol=1e-5 * np.abs(J_fd).max())
    u_star = np.array([1.6, 1.0, 1.3])  # every cable taut: a unique answer
    assert np.all(np.abs(fmap.predict_and_jacobian(u_star)[1]).max(axis=0) > 1e-3)
    target = solve_static(coarse_fem, u_star).p_tip_W
    res = IKSolver(fmap, cset).solve(target)  # from the centre: every cable taut
    assert res.status == "converged" and res.reachable
    np.testing.assert_allclose(res.u_motor, u_star, atol=1e-5)
    achieved = solve_static(coarse_fem, res.u_motor).p_tip_W  # an independent, cold solve
    assert np.linalg.norm(achieved - target) < 1e-7


def test_qp_terminates_on_an_ill_conditioned_six_motor_step():
    # A damped Gauss-Newton matrix of the six-cable arm (rank-3 J^T J + mu I, cond ~4e4)
    # met during IK: after a full step the recomputed step was ~8e-13 rad, above the
    # "p = 0" threshold, and the active-set method repeated it until max_iter.
    cs = CommandSet.from_robot(load_robot("six-cable"))
    H = np.array(
        [
            [
                8.4910814132539686e-07,
                2.6240080114553867e-06,
                1.3293405923759361e-05,
                -3.6398180165999449e-05,
                3.6364152697464370e-06,
                2.1504658608878588e-05,
            ],
            [
                2.6240080114553867e-06,
                3.6566898146432917e-04,
                -1.6029317316238826e-04,
                -4.4725639452051764e-04,
                5.8667846134026816e-04,
                -2.5127878688192248e-04,
            ],
            [
                1.3293405923759361e-05,
                -1.6029317316238826e-04,
                3.5083577609306641e-04,
                -4.2551539694975053e-04,
                -2.7521303175971086e-04,
                5.5531273578453744e-04,
            ],
            [
                -3.6398180165999449e-05,
                -4.4725639452051764e-04,
                -4.2551539694975053e-04,
                2.2762849535406921e-03,
                -7.8293815385428321e-04,
                -7.9398373031812808e-04,
            ],
            [
                3.6364152697464370e-06,
                5.8667846134026816e-04,
                -2.7521303175971086e-04,
                -7.8293815385428321e-04,
                9.7412477433812144e-04,
                -3.9744556757453410e-04,
            ],
            [
                2.1504658608878588e-05,
                -2.5127878688192248e-04,
                5.5531273578453744e-04,
                -7.9398373031812808e-04,
                -3.9744556757453410e-04,
                9.1680406638634283e-04,
            ],
        ]
    )
    c = np.array(
        [
            -5.7946242107349099e-05,
            -8.1374377233171856e-04,
            -6.5239693750748361e-04,
            3.2738333277760800e-03,
            -1.2537952669374830e-03,
            -1.0561744790605664e-03,
        ]
    )
    x0 = np.array([0.1293623260662785, 3.0, 3.0, 1.3903933433653302, 2.427650553501787, 2.412152510898937])
    x = cs.solve_qp(H, c, x0=x0)
    assert cs.contains(x)
    np.testing.assert_allclose(x, brute_force_qp(cs, H, c), atol=1e-9)


class _SlackArm:
    """A toy forward map with a slack cable: y = (u0, max(u1 - 1, 0), 0), so at u1 <= 1 the
    second Jacobian column is zero -- the plateau a learned model of an arm with slack has."""

    def predict_and_jacobian(self, u):
        u = np.asarray(u, float)
        taut = u[1] > 1.0
        return np.array([u[0], max(u[1] - 1.0, 0.0), 0.0]), np.array([[1.0, 0.0], [0.0, float(taut)], [0.0, 0.0]])

    def predict(self, u):
        u = np.atleast_2d(u)
        return np.stack([u[:, 0], np.maximum(u[:, 1] - 1.0, 0.0), 0 * u[:, 0]], axis=1)


def test_follow_leaves_a_slack_plateau_by_a_cold_retry():
    # warm-started from u1 = 0 (slack), the target at y1 = 0.5 is unreachable for LM: the
    # gradient in u1 is zero. follow() retries from the nearest seeds and reaches it;
    # without the retry it reports a miss, which is what the retry is for
    cs = CommandSet([0.0, 0.0], [3.0, 3.0])
    arm = _SlackArm()
    targets = np.array([[1.0, 0.0, 0.0], [1.2, 0.5, 0.0], [1.4, 0.6, 0.0]])
    seeds = grid_seeds(arm, cs, 7)
    plain = IKSolver(arm, cs, IKConfig(retry_cold=False), seeds=seeds).follow(targets, u0=np.array([1.0, 0.0]))
    assert not plain.reachable[1] and plain.residual_m[1] > 0.4
    fixed = IKSolver(arm, cs, seeds=seeds).follow(targets, u0=np.array([1.0, 0.0]))
    assert np.all(fixed.reachable) and np.all(fixed.residual_m < 1e-8)
    assert fixed.iterations[1] > plain.iterations[1]  # the retry's work is counted
