"""The Latin hypercube restricted to the safe set (lab.data.designs.lhs_commands)."""

import dataclasses

import numpy as np
import pytest

from lab.data import DESIGNS, design_commands, empty_strata, random_commands
from lab.data.designs import axis_ranges, lhs_commands
from lab.description import load_robot, shipped_robots


def _tight(robot, ratio=0.5):
    lim = dataclasses.replace(robot.safety_limits[0], max_sum_over_u_max=ratio)
    return dataclasses.replace(robot, safety_limits=(lim,))


def test_lhs_is_a_design():
    assert "lhs" in DESIGNS


@pytest.mark.parametrize("name", shipped_robots())
def test_safe_n_rows_seeded_and_exactly_latin(name):
    robot = load_robot(name)
    for n in (1, 2, 9, 100, 2000):
        u = lhs_commands(robot, n, seed=5)
        assert u.shape == (n, robot.n_inputs)
        assert np.all(robot.is_safe(u))
        assert np.array_equal(u, lhs_commands(robot, n, seed=5))
        assert np.array_equal(u, design_commands(robot, n, "lhs", seed=5))
        # every one of the n equally likely strata of every motor holds exactly one command
        assert np.all(empty_strata(robot, u) == 0)
    assert not np.array_equal(lhs_commands(robot, 50, seed=0), lhs_commands(robot, 50, seed=1))


def test_the_safety_rule_cuts_the_box_so_a_plain_hypercube_would_not_do():
    """The repair matters: a raw n-point hypercube of the shipped arm has unsafe points."""
    from scipy.stats import qmc

    robot = load_robot("three-cable")
    raw = qmc.LatinHypercube(d=3, rng=np.random.default_rng(0)).random(200) * robot.u_max_rad
    assert not np.all(robot.is_safe(raw))
    u = lhs_commands(robot, 200, seed=0)
    assert np.all(robot.is_safe(u)) and np.all(empty_strata(robot, u) == 0)


@pytest.mark.parametrize("name", shipped_robots())
def test_better_stratified_per_motor_than_random_and_sobol(name):
    robot = load_robot(name)
    n = 60
    for seed in range(3):
        lhs = empty_strata(robot, lhs_commands(robot, n, seed=seed))
        rand = empty_strata(robot, random_commands(robot, n, seed=seed))
        sobol = empty_strata(robot, design_commands(robot, n, "sobol", seed=seed))
        assert lhs.max() == 0
        assert rand.min() >= 0.2 * n and sobol.min() > 0  # independent draws leave about n/e empty


def test_a_tight_rule_still_gives_n_safe_commands_and_the_fallback_works(monkeypatch):
    import lab.data.designs as designs

    robot = _tight(load_robot("three-cable"))
    assert np.allclose(axis_ranges(robot), 0.5 * robot.u_max_rad)
    for n in (1, 7, 40):
        u = lhs_commands(robot, n, seed=2)
        assert u.shape == (n, 3) and np.all(robot.is_safe(u))
        assert np.all(u.sum(axis=1) <= 0.5 * robot.u_max_rad + 1e-9)
        assert np.array_equal(u, lhs_commands(robot, n, seed=2))
        assert np.all(empty_strata(robot, u) == 0)
    # where no swap helps: oversample, keep the safe points, thin by strata
    monkeypatch.setattr(designs, "_repair_lhs", lambda *a: None)
    for r in (robot, load_robot("three-cable")):
        u = lhs_commands(r, 60, seed=1)
        assert u.shape == (60, 3) and np.all(r.is_safe(u))
        assert np.array_equal(u, lhs_commands(r, 60, seed=1))
        assert empty_strata(r, u).max() < empty_strata(r, random_commands(r, 60, seed=1)).min()


def test_the_strata_follow_the_safe_set():
    """High angles are rarer in the safe set (they need the other motors low): the strata
    of a motor are equally likely there, so an LHS puts fewer commands near u_max than a
    hypercube of the box would, about as many as uniform draws over the safe set."""
    robot = load_robot("three-cable")
    u = lhs_commands(robot, 3000, seed=0) / robot.u_max_rad
    ref = random_commands(robot, 200_000, seed=0) / robot.u_max_rad
    assert abs(np.mean(u > 0.9) - np.mean(ref > 0.9)) < 0.005
    assert np.mean(u > 0.9) < 0.08  # a box hypercube: 0.10


def test_empty_strata_counts():
    from lab.data.designs import _safe_marginals

    robot = load_robot("three-cable")
    marg = _safe_marginals(robot)
    n = 4
    mid = np.column_stack([np.quantile(marg[j], (np.arange(n) + 0.5) / n) for j in range(3)])
    assert empty_strata(robot, mid).tolist() == [0, 0, 0]  # one per stratum of each motor
    assert empty_strata(robot, np.repeat(mid[:1], n, axis=0)).tolist() == [3, 3, 3]  # all in the first
    edge = np.vstack([mid[:3], np.full(3, robot.u_max_rad)])  # u_max is in the last stratum, not past it
    assert empty_strata(robot, edge).tolist() == [0, 0, 0]
