"""The IK's settings: IKConfig validation, the solver a command builds for a model
(IKSolver.for_model), the track flags built from IKConfig, and a solver that never changes."""

import copy
import dataclasses

import numpy as np
import pytest

from lab.cli import build_parser
from lab.cli.flags import spec_from_args
from lab.control.command_set import CommandSet
from lab.control.ik import IKConfig, IKSolver, grid_seeds
from lab.control.soft_ik import FEMForwardMap
from lab.errors import InputError
from lab.learn.mlp_init import init_mlp


@pytest.fixture(scope="module")
def net3():
    rng = np.random.default_rng(0)
    u = rng.uniform(0, 3, (80, 3))
    return init_mlp(u, 0.15 + 0.05 * np.tanh(0.5 * u @ rng.normal(size=(3, 3))), (8,), seed=2)


@pytest.mark.parametrize(
    "field, value, named",
    [
        ("method", "newton", "method"),
        ("reg_weight", -1.0, "reg.weight"),
        ("reg_weight", np.nan, "reg.weight"),
        ("reg_weight", "0.1", "reg_weight"),
        ("posture_weight", -1e-6, "posture.weight"),
        ("posture_weight", np.inf, "posture.weight"),
        ("spread_weight", np.nan, "spread.weight"),
        ("spread_weight", None, "spread_weight"),
        ("max_spread_m", 0.0, "max_spread_m"),
        ("max_spread_m", -1.0, "max_spread_m"),
        ("tol_m", -1e-9, "tol_m"),
        ("reach_tol_m", np.nan, "reach_tol_m"),
        ("tol_stationary", -1.0, "tol_stationary"),
        ("max_iter", 0, "max_iter"),
        ("max_iter", 2.5, "max_iter"),
        ("seed_levels", 0, "seed_levels"),
        ("u_posture", [np.nan, 1.0, 1.0], "u_posture"),
        ("u_posture", "centre", "u_posture"),
    ],
)
def test_each_bad_setting_is_refused_naming_it(field, value, named):
    with pytest.raises(InputError, match=named):
        IKConfig(**{field: value})


def test_a_config_is_frozen_hashable_and_plain():
    cfg = IKConfig("gd", reg_weight=np.float64(1e-6), max_iter=np.int64(50), u_posture=np.array([1.0, 2.0, 0.5]))
    assert cfg.u_posture == (1.0, 2.0, 0.5) and type(cfg.reg_weight) is float and type(cfg.max_iter) is int
    assert hash(cfg) == hash(IKConfig("gd", reg_weight=1e-6, max_iter=50, u_posture=(1.0, 2.0, 0.5)))
    with pytest.raises(dataclasses.FrozenInstanceError):
        cfg.reg_weight = 0.0
    assert IKConfig() == IKConfig("lm", reg_weight=0.0, posture_weight=0.0, spread_weight=0.0)
    auto = IKConfig.automatic(spread_weight=0.1)
    assert (auto.method, auto.reg_weight, auto.posture_weight, auto.spread_weight) == (None, None, None, 0.1)


def test_the_solver_fills_in_its_config_and_checks_it_against_the_arm(net3, three_cable):
    cs = CommandSet.from_robot(three_cable)
    solver = IKSolver(net3, cs, IKConfig("gd"))
    assert solver.config.max_iter == 20000 and solver.config.max_spread_m is None
    np.testing.assert_array_equal(solver.u_posture, solver.centre)
    assert solver.config.u_posture == tuple(solver.centre)
    assert IKSolver(net3, cs, IKConfig(method=None)).config.method == "lm"
    with pytest.raises(InputError, match="u_posture"):
        IKSolver(net3, cs, IKConfig(u_posture=(3.0, 3.0, 3.0)))  # beyond the safety limit
    with pytest.raises(InputError, match="u_posture"):
        IKSolver(net3, cs, IKConfig(u_posture=(1.0, 1.0)))
    with pytest.raises(InputError, match="ensemble members"):
        IKSolver(net3, cs, IKConfig(spread_weight=0.5))
    with pytest.raises(InputError, match="IKConfig"):
        IKSolver(net3, cs, "lm")


def test_solve_and_follow_leave_the_solver_unchanged(net3, three_cable):
    cs = CommandSet.from_robot(three_cable)
    solver = IKSolver(net3, cs, IKConfig(reg_weight=1e-6, posture_weight=1e-6), seeds=grid_seeds(net3, cs, 4))
    shared = ("forward", "commands")  # the model and the allowed set: the solver's by reference
    before = {k: v if k in shared else copy.deepcopy(v) for k, v in vars(solver).items()}
    config = solver.config
    target = net3.predict(np.array([1.0, 0.6, 1.3]))
    solver.solve(target, u0=np.full(3, 1.0), reg_weight=1e-3)
    solver.solve(target)
    solver.follow([target, target + 1e-4])
    after = vars(solver)
    assert solver.config is config and after.keys() == before.keys()
    for key, value in before.items():
        if key in shared:
            assert after[key] is value, key
        elif isinstance(value, tuple) and value and isinstance(value[0], np.ndarray):
            assert all(np.array_equal(a, b) for a, b in zip(value, after[key])), key
        elif isinstance(value, np.ndarray):
            np.testing.assert_array_equal(after[key], value, err_msg=key)
        else:
            assert after[key] == value, key


def test_nothing_in_the_solver_changes_even_during_a_solve(net3, three_cable):
    """The forward map looks at the solver at every evaluation: no attribute is rebound
    mid-solve (a regulariser weight passed to solve() travels as an argument)."""
    seen = []

    class Watching:
        def predict(self, u):
            return net3.predict(u)

        def predict_and_jacobian(self, u):
            seen.append({k: id(v) for k, v in vars(solver).items()})
            return net3.predict_and_jacobian(u)

    cs = CommandSet.from_robot(three_cable)
    solver = IKSolver(Watching(), cs, IKConfig(reg_weight=1e-6, posture_weight=1e-6))
    ids = {k: id(v) for k, v in vars(solver).items()}
    target = net3.predict(np.array([1.0, 0.6, 1.3]))
    solver.solve(target, u0=np.full(3, 1.0), reg_weight=1e-3)
    solver.follow([target, target + 1e-4])
    assert len(seen) > 3 and all(s == ids for s in seen)


def test_for_model_seeds_from_a_grid_and_checks_the_model(net3, three_cable):
    solver = IKSolver.for_model(net3, three_cable)
    cs = CommandSet.from_robot(three_cable)
    np.testing.assert_array_equal(solver.seeds[0], grid_seeds(net3, cs, 7)[0])
    assert solver.config.reg_weight is None and solver.config.method == "lm" and not solver.notes
    coarse = IKSolver.for_model(net3, three_cable, IKConfig.automatic(seed_levels=3))
    assert len(coarse.seeds[0]) == len(grid_seeds(net3, cs, 3)[0])
    plain = IKSolver.for_model(net3, three_cable, IKConfig("gd", max_spread_m=2e-3))
    assert plain.config.method == "gd" and plain.config.reg_weight == 0.0 and plain.config.max_spread_m == 2e-3

    class Inverse:
        def command(self, y):
            return np.zeros(3)

    with pytest.raises(InputError, match="direct inverse model"):
        IKSolver.for_model(Inverse(), three_cable)
    wide = init_mlp(np.zeros((4, 4)), np.zeros((4, 3)), (4,), seed=0)
    with pytest.raises(InputError, match="4 inputs"):
        IKSolver.for_model(wide, three_cable)
    with pytest.raises(InputError, match="model or an FEM"):
        IKSolver.for_model(None, three_cable)


def test_for_model_without_a_model_is_soft_ik_through_the_fem(three_cable, coarse_fem):
    solver = IKSolver.for_model(None, three_cable, IKConfig.automatic(max_spread_m=1e-3), fem=coarse_fem)
    assert isinstance(solver.forward, FEMForwardMap) and solver.seeds is None
    assert solver.config.method == "lm" and solver.config.max_spread_m is None  # the FEM has no spread


def test_the_track_flags_build_the_config():
    parser = build_parser()
    base = ["track", "--model", "m.npz", "--trajectory", "circle", "--out", "o.json"]
    auto = spec_from_args(IKConfig, parser.parse_args(base), base=IKConfig.automatic())
    assert auto == IKConfig.automatic()
    args = parser.parse_args([*base, "--solver", "gd", "--reg-weight", "1e-6", "--spread-weight", "0.5"])
    cfg = spec_from_args(IKConfig, args, base=IKConfig.automatic())
    assert cfg == IKConfig.automatic(method="gd", reg_weight=1e-6, spread_weight=0.5)
    with pytest.raises(InputError, match="IKConfig.posture_weight"):
        spec_from_args(IKConfig, parser.parse_args([*base, "--posture-weight", "-1"]), base=IKConfig.automatic())
