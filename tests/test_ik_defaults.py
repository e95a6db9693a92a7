"""IK defaults that need no expert flags: automatic regularisation of redundant arms, restarts
from slack plateaus, the ensemble-spread penalty and flag, and the derivative-free IK."""

import numpy as np
import pytest
from helpers import fd_jacobian

from lab.control.command_set import CommandSet
from lab.control.follow import AUTO_WEIGHT_REL, auto_weight, follow_weights, slack_motors
from lab.control.ik import IKConfig, IKSolver, grid_seeds
from lab.control.ik_objective import Objective
from lab.control.spread import DEFAULT_MAX_SPREAD_M, predicted_spread_m, spread_rows
from lab.control.trajectories import circle
from lab.data.dataset import read_dataset
from lab.learn.mlp_init import init_mlp

ANGLES = np.radians([45.0, 135.0, 225.0, 315.0])
#: Tip displacement per rad of cable tension (3, 4) m/rad: each cable bends the tip
#: towards its side and shortens the arm a little.
B_CABLES = np.vstack([np.full(4, -0.005), 0.02 * np.cos(ANGLES), 0.02 * np.sin(ANGLES)])
TIP_REST = np.array([0.18, 0.0, 0.0])


class SlackArm4:
    """A redundant four-cable toy: ``y = y0 + B max(u - 0.3, 0)``. A cable below 0.3 rad is
    slack, its Jacobian column exactly zero: the plateau of a learned model of such an arm."""

    def predict_and_jacobian(self, u):
        u = np.asarray(u, float)
        return TIP_REST + B_CABLES @ np.maximum(u - 0.3, 0.0), B_CABLES * (u > 0.3)

    def predict(self, u):
        u = np.atleast_2d(u)
        return TIP_REST + np.maximum(u - 0.3, 0.0) @ B_CABLES.T


class SlackArm2:
    """Not redundant: y = (u0, max(u1 - 1, 0), 0); the second cable is slack below 1 rad."""

    def predict_and_jacobian(self, u):
        u = np.asarray(u, float)
        return np.array([u[0], max(u[1] - 1.0, 0.0), 0.0]), np.array([[1.0, 0.0], [0.0, float(u[1] > 1.0)], [0, 0]])

    def predict(self, u):
        u = np.atleast_2d(u)
        return np.stack([u[:, 0], np.maximum(u[:, 1] - 1.0, 0.0), 0 * u[:, 0]], axis=1)


@pytest.fixture(scope="module")
def box4():
    return CommandSet(np.zeros(4), np.full(4, 3.0), np.ones((1, 4)), [8.0])


def slack_targets(n=12):
    """Tips all four cables can reach with every cable taut (tensions 0.8 +- 0.5 rad)."""
    t = 2 * np.pi * np.arange(n) / n
    tension = 0.8 + 0.5 * np.column_stack([np.cos(t - a) for a in ANGLES])
    return TIP_REST + tension @ B_CABLES.T


# ------------------------------------------------------------------ automatic regularisation
def test_auto_restarts_a_redundant_arm_off_its_slack_plateau(box4):
    """From all cables slack (u = 0) the gradient is zero: the plain IK without restarts stops
    at once and misses everything. The automatic default restarts the missed first point
    regularised towards the posture (every cable taut), polishes, and reaches it exactly; the
    later points follow from there by warm starts, unregularised."""
    arm, targets, u0 = SlackArm4(), slack_targets(), np.zeros(4)
    plain = IKSolver(arm, box4, IKConfig(retry_cold=False)).follow(targets, u0=u0)
    assert not plain.reachable.any() and plain.info["regularisation"] == "explicit: none"
    auto = IKSolver(arm, box4, IKConfig(reg_weight=None, posture_weight=None)).follow(targets, u0=u0)
    assert auto.reachable.all() and auto.residual_m.max() < 1e-8
    assert all(box4.contains(u) for u in auto.u_motor)
    w = AUTO_WEIGHT_REL * np.sum(B_CABLES**2) / 4  # |J|_F^2 / m at the centre, every cable taut
    assert auto.info["restart_weight"] == pytest.approx(w)
    assert auto.info["reg_weight"] == 0.0 and auto.info["posture_weight"] == 0.0
    assert auto.info["redundant"] and auto.info["regularisation"].startswith("auto: none while targets are reached")
    assert auto.info["restarts"] == 1 and auto.info["recovered"] == 1 and auto.info["slack_plateaus"] == 1
    # the restart is regularised: a plain restart from the posture lands elsewhere on the family
    plain_restart = IKSolver(arm, box4, IKConfig(reg_weight=0.0, posture_weight=0.0)).follow(targets[:1], u0=u0)
    assert plain_restart.reachable.all()
    assert np.linalg.norm(auto.u_motor[0] - 1.5) < np.linalg.norm(plain_restart.u_motor[0] - 1.5)


def test_explicit_weights_regularise_every_point(box4):
    """Explicit weights: every point regularised (then polished) -- from the slack start the
    pull towards the posture alone lifts the cables, no restart needed."""
    arm, targets = SlackArm4(), slack_targets()
    config = IKConfig(reg_weight=1e-6, posture_weight=1e-6, retry_cold=False)
    res = IKSolver(arm, box4, config).follow(targets, u0=np.zeros(4))
    assert res.reachable.all() and res.info["restarts"] == 0
    assert res.info["reg_weight"] == 1e-6 and res.info["regularisation"].startswith("explicit: continuity + posture")


def test_slack_plateau_miss_restarts_from_the_posture(box4):
    """Without a regulariser and without seeds, a point that misses on a slack plateau is solved
    again from the posture, where every cable is taut; the info counts it."""
    arm, targets = SlackArm4(), slack_targets(4)
    res = IKSolver(arm, box4, IKConfig(reg_weight=0.0, posture_weight=0.0)).follow(targets, u0=np.zeros(4))
    assert res.reachable.all()
    assert res.info["slack_plateaus"] == 1 and res.info["restarts"] == 1 and res.info["recovered"] == 1
    first = IKSolver(arm, box4, IKConfig(retry_cold=False)).follow(targets[:1], u0=np.zeros(4))
    assert res.iterations[0] > first.iterations[0]  # the restart's work is counted


def test_slack_restart_also_for_a_non_redundant_arm():
    cs = CommandSet([0.0, 0.0], [3.0, 3.0])
    arm = SlackArm2()
    targets = np.array([[1.0, 0.0, 0.0], [1.2, 0.5, 0.0], [1.4, 0.6, 0.0]])
    solver = IKSolver(arm, cs, IKConfig(reg_weight=None, posture_weight=None))  # no seeds: only the posture
    res = solver.follow(targets, u0=np.array([1.0, 0.0]))
    assert res.reachable.all() and res.info["slack_plateaus"] == 1 and res.info["recovered"] == 1
    assert res.info["reg_weight"] == 0.0 and "not redundant" in res.info["regularisation"]
    np.testing.assert_array_equal(slack_motors(solver, [1.0, 0.0]), [1])
    assert len(slack_motors(solver, [1.0, 2.0])) == 0


def test_explicit_weights_override_and_zero_is_off(box4):
    arm = SlackArm4()
    s = IKSolver(arm, box4, IKConfig(reg_weight=2e-6, posture_weight=0.0))
    assert follow_weights(s)[:4] == (2e-6, 0.0, 2e-6, False)
    w_c, w_p, w_r, to_posture, how = follow_weights(IKSolver(arm, box4, IKConfig(reg_weight=None, posture_weight=3e-6)))
    assert (w_c, w_p, w_r, to_posture) == (0.0, 3e-6, 3e-6, True) and "auto where not given" in how
    off = IKSolver(arm, box4, IKConfig(reg_weight=0.0, posture_weight=0.0))
    assert follow_weights(off)[:4] == (0.0, 0.0, 0.0, False)
    w_r, to_posture = follow_weights(IKSolver(arm, box4, IKConfig(reg_weight=None, posture_weight=None)))[2:4]
    assert w_r == pytest.approx(auto_weight(s)) and to_posture


class Linear:
    def __init__(self, has_jacobian=True):
        self.has_jacobian = has_jacobian

    def predict(self, u):
        return TIP_REST + np.asarray(u, float) @ B_CABLES.T

    def predict_and_jacobian(self, u):
        assert self.has_jacobian, "the derivative-free path must not ask for a Jacobian"
        return self.predict(u), B_CABLES.copy()


def test_auto_weight_without_a_jacobian_fits_the_seeds(box4):
    """The weight's scale |J|_F^2 / m comes from the Jacobian, or from a linear fit to the seeds."""
    want = AUTO_WEIGHT_REL * np.sum(B_CABLES**2) / 4
    assert auto_weight(IKSolver(Linear(), box4)) == pytest.approx(want, rel=1e-12)
    blind = Linear(has_jacobian=False)
    dfo = IKConfig("dfo")
    assert auto_weight(IKSolver(blind, box4, dfo, seeds=grid_seeds(blind, box4, 3))) == pytest.approx(want, rel=1e-9)
    assert auto_weight(IKSolver(blind, box4, dfo)) == pytest.approx(want, rel=1e-9)  # a cross about the posture


@pytest.fixture(scope="module")
def three_net():
    from lab.learn.train import train

    u, y, _ = read_dataset("data/sim_three_cable.csv")
    return train(u, y, (10, 10), seed=0, epochs=40).model


def test_non_redundant_arm_is_unchanged_by_auto(three_net, three_cable):
    """Table I's arm: the automatic default is exactly the unregularised IK."""
    targets = circle(30)
    seeds = grid_seeds(three_net, CommandSet.from_robot(three_cable), 5)
    cs = CommandSet.from_robot(three_cable)
    auto = IKSolver(three_net, cs, IKConfig(reg_weight=None, posture_weight=None), seeds=seeds).follow(targets)
    off = IKSolver(three_net, cs, seeds=seeds).follow(targets)
    np.testing.assert_array_equal(auto.u_motor, off.u_motor)
    np.testing.assert_array_equal(auto.iterations, off.iterations)
    assert auto.info["reg_weight"] == 0.0 and "not redundant" in auto.info["regularisation"]
    solver = IKSolver.for_model(three_net, three_cable)
    assert solver.config.reg_weight is None and solver.config.posture_weight is None and not solver.redundant


# ------------------------------------------------------------------ ensemble spread
class FakeEnsemble:
    """Two small networks on four motors, with the duck-typed ensemble interface."""

    def __init__(self, std_scale=None):
        rng = np.random.default_rng(4)
        u = rng.uniform(0, 3, (60, 4))
        y = TIP_REST + 0.02 * np.tanh(u @ rng.normal(size=(4, 3)) / 3)
        self.members = [init_mlp(u, y, (6,), seed=s) for s in (1, 2)]
        if std_scale is not None:
            self.predict_with_std = lambda v: (self.predict(v), std_scale * np.ones(3))

    def predict(self, u):
        return np.mean([m.predict(u) for m in self.members], axis=0)

    def predict_and_jacobian(self, u):
        parts = [m.predict_and_jacobian(u) for m in self.members]
        return np.mean([p[0] for p in parts], axis=0), np.mean([p[1] for p in parts], axis=0)


def spread_sq(ens, u):
    """S(u) for two members, written independently: |y_1 - y_2|^2 / 4 (m^2)."""
    y1, y2 = (m.predict(u) for m in ens.members)
    return np.sum((y1 - y2) ** 2, axis=-1) / 4.0


def test_spread_rows_and_their_gradient_against_finite_differences():
    ens, s = FakeEnsemble(), 0.7
    u = np.array([0.8, 1.9, 1.1, 2.4])
    r, J = spread_rows(ens, u, s)
    assert r.shape == (6,) and J.shape == (6, 4)
    assert 0.5 * r @ r == pytest.approx(0.5 * s * spread_sq(ens, u), rel=1e-12)
    np.testing.assert_allclose(J, fd_jacobian(lambda v: spread_rows(ens, v, s)[0], u), atol=1e-9)
    grad_fd = fd_jacobian(lambda v: 0.5 * s * spread_sq(ens, v), u)
    np.testing.assert_allclose(J.T @ r, grad_fd, rtol=1e-6, atol=1e-12)
    assert predicted_spread_m(ens, u) == pytest.approx(np.sqrt(spread_sq(ens, u)), rel=1e-12)
    assert predicted_spread_m(FakeEnsemble(std_scale=2e-3), u) == pytest.approx(2e-3 * np.sqrt(3))


@pytest.mark.parametrize("method", ["lm", "gd"])
def test_ik_gradient_with_spread_and_regulariser_is_exact(box4, method):
    ens = FakeEnsemble()
    solver = IKSolver(ens, box4, IKConfig(method, reg_weight=3e-4, spread_weight=0.5))
    target, u_ref, u = np.array([0.17, 0.01, -0.005]), np.full(4, 1.2), np.array([0.8, 1.9, 1.1, 2.4])
    f = Objective(solver.forward, target, u_ref, solver.config.reg_weight, solver.config.spread_weight)
    _, _, rows = f.evaluate(u)
    g = f.gradient(u, rows)
    g_fd = fd_jacobian(lambda v: f.evaluate(v)[1], u)
    np.testing.assert_allclose(g, g_fd, rtol=1e-6, atol=1e-12)


def test_spread_penalty_picks_where_the_members_agree_and_flags(box4):
    ens = FakeEnsemble()
    u_star = np.array([1.0, 2.0, 1.5, 0.7])
    target = ens.predict(u_star)
    plain = IKSolver(ens, box4).solve(target, u0=u_star)
    assert plain.residual_m < 1e-8 and plain.spread_m == pytest.approx(predicted_spread_m(ens, u_star))
    pen = IKSolver(ens, box4, IKConfig(spread_weight=0.01)).solve(target, u0=u_star)
    # four motors: along the family of commands that reach the target, to where the members
    # agree better, paying a small tip error for it (more for a larger weight)
    assert pen.spread_m < 0.5 * plain.spread_m and pen.residual_m < 0.02 * plain.spread_m
    assert box4.contains(pen.u_motor) and pen.status == "stationary"
    heavy = IKSolver(ens, box4, IKConfig(spread_weight=1.0)).solve(target, u0=u_star)
    assert heavy.spread_m < pen.spread_m and heavy.residual_m > pen.residual_m
    limit = 0.75 * plain.spread_m
    flagged = IKSolver(ens, box4, IKConfig(max_spread_m=limit)).follow([target], u0=u_star)
    assert flagged.uncertain.tolist() == [True] and flagged.info["n_uncertain"] == 1
    assert flagged.spread_m[0] == pytest.approx(flagged.results[0].spread_m)
    calm = IKSolver(ens, box4, IKConfig(spread_weight=0.01, max_spread_m=limit)).follow([target], u0=u_star)
    assert calm.uncertain.tolist() == [False] and calm.info["n_uncertain"] == 0


def test_spread_flag_defaults_and_bad_settings(box4):
    assert IKSolver(FakeEnsemble(), box4).config.max_spread_m == DEFAULT_MAX_SPREAD_M
    no_spread = IKSolver(SlackArm4(), box4)
    assert no_spread.config.max_spread_m is None
    res = no_spread.solve(slack_targets(1)[0], u0=np.full(4, 1.5))
    assert np.isnan(res.spread_m) and not res.uncertain
    with pytest.raises(ValueError, match="ensemble members"):
        IKSolver(SlackArm4(), box4, IKConfig(spread_weight=1.0))
    with pytest.raises(ValueError, match="max_spread_m"):
        IKSolver(FakeEnsemble(), box4, IKConfig(max_spread_m=-1.0))
    with pytest.raises(ValueError, match="spread.weight"):
        IKSolver(FakeEnsemble(), box4, IKConfig(spread_weight=np.nan))


# ------------------------------------------------------------------ derivative-free IK
class Blind:
    """A smooth forward map whose Jacobian is hidden: ``predict`` only."""

    has_jacobian = False
    n_u, n_y = 3, 3

    def __init__(self, net):
        self.net, self.calls = net, 0

    def predict(self, u):
        self.calls += 1
        return self.net.predict(u)

    def predict_and_jacobian(self, u):
        raise AssertionError("the derivative-free IK asked for a Jacobian")


@pytest.fixture(scope="module")
def toy_net():
    rng = np.random.default_rng(0)
    u = rng.uniform(0, 3, (80, 3))
    return init_mlp(u, 0.05 * np.tanh(0.5 * u @ rng.normal(size=(3, 3))), (8,), seed=2)


def test_dfo_reaches_targets_inside_the_allowed_set(toy_net, three_cable):
    cs = CommandSet.from_robot(three_cable)
    blind = Blind(toy_net)
    solver = IKSolver(blind, cs, IKConfig("dfo"), seeds=grid_seeds(blind, cs, 5))
    rng = np.random.default_rng(1)
    for _ in range(5):
        u_star = cs.project(rng.uniform(0.2, 2.8, 3))
        target = toy_net.predict(u_star)
        before = blind.calls
        res = solver.solve(target)
        assert cs.contains(res.u_motor)
        assert np.linalg.norm(toy_net.predict(res.u_motor) - target) == pytest.approx(res.residual_m, abs=1e-15)
        lm = IKSolver(toy_net, cs, seeds=solver.seeds).solve(target)
        assert res.residual_m <= max(1e-8, 2 * lm.residual_m)  # as good as LM with the Jacobian
        assert res.evaluations > res.iterations > 0 and res.time_s > 0
        assert blind.calls - before <= res.evaluations  # batched: calls, not points
    beyond = toy_net.predict(np.array([3.0, 3.0, 0.5])) + np.array([0.0, 0.0, 0.02])
    res, lm = solver.solve(beyond), IKSolver(toy_net, cs).solve(beyond)
    assert not res.reachable and res.status == "stationary" and cs.contains(res.u_motor)
    assert res.residual_m <= lm.residual_m + 1e-9  # the best allowed answer, as LM's
    np.testing.assert_allclose(res.u_motor, lm.u_motor, atol=1e-4)
    assert np.any(cs.G @ res.u_motor >= cs.h - 1e-6)  # on the boundary of the allowed set


def test_dfo_follows_a_trajectory_warm_started(toy_net, three_cable):
    cs = CommandSet.from_robot(three_cable)
    blind = Blind(toy_net)
    solver = IKSolver(blind, cs, IKConfig("dfo"), seeds=grid_seeds(blind, cs, 5))
    u_path = cs.project(np.array([1.5, 1.0, 1.2])) + 0.3 * np.column_stack(
        [np.cos(np.linspace(0, 2, 15) + k) for k in range(3)]
    )
    targets = toy_net.predict(u_path)
    plan = solver.follow(targets)
    assert plan.reachable.all() and all(cs.contains(u) for u in plan.u_motor)
    cold = [solver.solve(t) for t in targets[1:]]
    assert sum(r.evaluations for r in plan.results[1:]) < 0.8 * sum(r.evaluations for r in cold)


def test_for_model_picks_the_derivative_free_ik_and_says_so(toy_net, three_cable):
    solver = IKSolver.for_model(Blind(toy_net), three_cable)
    assert solver.config.method == "dfo" and any("no Jacobian" in n for n in solver.notes)
    with pytest.raises(ValueError, match="needs the model's Jacobian"):
        IKSolver.for_model(Blind(toy_net), three_cable, IKConfig.automatic(method="lm"))
    explicit = IKSolver.for_model(Blind(toy_net), three_cable, IKConfig.automatic(method="dfo"))
    assert explicit.config.method == "dfo" and not explicit.notes
    plain = IKSolver.for_model(toy_net, three_cable)
    assert plain.config.method == "lm" and not plain.notes


def test_track_cli_records_the_regularisation_and_the_uncertainty_keys(tmp_path, three_net):
    import json

    from lab.cli import main

    model = tmp_path / "net.npz"
    three_net.save(model)
    out = tmp_path / "c.json"
    args = [
        "track",
        "--model",
        str(model),
        "--trajectory",
        "circle",
        "--n-points",
        "4",
        "--n-rings",
        "1",
        "--n-axial",
        "6",
    ]
    assert main([*args, "--out", str(out)]) == 0
    doc = json.loads(out.read_text())
    sol = doc["info"]["solver"]
    assert sol["reg_weight_setting"] == "auto" and sol["posture_weight_setting"] == "auto"
    assert sol["reg_weight"] == 0.0 and "not redundant" in sol["regularisation"]
    assert sol["max_spread_m"] is None and sol["ik"] == {"slack_plateaus": 0, "restarts": 0, "recovered": 0}
    assert doc["uncertain"] == [False] * 4 and doc["info"]["n_uncertain"] == 0
    assert doc["predicted_spread_m"] == [None] * 4
    assert main([*args, "--reg-weight", "1e-6", "--posture-weight", "0", "--out", str(out)]) == 0
    sol = json.loads(out.read_text())["info"]["solver"]
    assert sol["reg_weight"] == 1e-6 and sol["reg_weight_setting"] == 1e-6
    assert sol["regularisation"].startswith("explicit: continuity + posture")
    assert main([*args, "--max-spread-mm", "-1", "--out", str(out)]) == 2
    assert main([*args, "--spread-weight", "1", "--out", str(out)]) == 2  # needs an ensemble


def test_a_deep_ensemble_flags_targets_just_outside_its_data(three_cable):
    """An ensemble trained on the commands with u0 <= 2 rad: IK for tips of its own data is
    not flagged; for tips one grid step further (u0 = 2.5 rad) the IK still "reaches" them
    (the nets extrapolate, confidently wrong), but the members disagree and the answers are
    flagged ``uncertain``."""
    from lab.learn.ensemble import train_ensemble

    u, y, _ = read_dataset("data/sim_three_cable.csv")
    inside = u[:, 0] <= 2.0
    ens = train_ensemble(u[inside], y[inside], (10, 10), k=5, seed=0, epochs=60)
    solver = IKSolver.for_model(ens, three_cable)
    assert solver.config.max_spread_m == DEFAULT_MAX_SPREAD_M
    known = solver.follow(y[inside][::20])
    beyond = solver.follow(y[np.isclose(u[:, 0], 2.5)][::4])
    assert not known.uncertain.any()
    assert beyond.reachable.mean() >= 0.8 and beyond.uncertain.mean() >= 0.8
    assert np.median(beyond.spread_m) > 5 * np.median(known.spread_m)


def test_track_cli_with_an_ensemble_flags_and_penalises_the_spread(tmp_path):
    import json

    from lab.cli import main
    from lab.learn.ensemble import train_ensemble

    u, y, _ = read_dataset("data/sim_three_cable.csv")
    model = tmp_path / "ens.npz"
    train_ensemble(u, y, (6,), k=2, seed=0, epochs=10).save(model)
    out = tmp_path / "c.json"
    args = [
        "track",
        "--model",
        str(model),
        "--trajectory",
        "circle",
        "--n-points",
        "4",
        "--n-rings",
        "1",
        "--n-axial",
        "6",
    ]
    assert main([*args, "--max-spread-mm", "1e-6", "--out", str(out)]) == 0  # a nanometre: all flagged
    doc = json.loads(out.read_text())
    assert doc["uncertain"] == [True] * 4 and doc["info"]["n_uncertain"] == 4
    assert all(s > 1e-9 for s in doc["predicted_spread_m"]) and doc["info"]["solver"]["max_spread_m"] == 1e-9
    assert main([*args, "--spread-weight", "0.01", "--out", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert (
        doc["info"]["solver"]["spread_weight"] == 0.01 and doc["info"]["solver"]["max_spread_m"] == DEFAULT_MAX_SPREAD_M
    )


def test_lm_damps_more_when_its_step_matrix_is_singular(box4, monkeypatch):
    """On a redundant arm J^T J is singular; after many good steps mu can vanish against it
    (seen on a four-cable net: LinAlgError). LM then damps more instead of failing."""
    import lab.control.ik_descent as ik_module

    real_solve, calls = np.linalg.solve, []

    def flaky_solve(H, g):
        calls.append(1)
        if len(calls) == 1:
            raise np.linalg.LinAlgError("Singular matrix")
        return real_solve(H, g)

    monkeypatch.setattr(ik_module.np.linalg, "solve", flaky_solve)
    target = TIP_REST + np.array([0.9, 1.1, 0.7, 1.3]) @ B_CABLES.T
    res = IKSolver(Linear(), box4).solve(target, u0=np.full(4, 1.5))
    assert res.reachable and res.residual_m < 1e-8 and len(calls) >= 2
