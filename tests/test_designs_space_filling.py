"""Space-filling designs over the safe command set (lab.data.designs.design_commands) and
``python -m lab capture --design``."""

import dataclasses

import numpy as np
import pytest
from sweep import Case, run_case

from lab.cli import main
from lab.cli.capture import add_parser
from lab.data import DESIGNS, design_commands, min_distance, read_dataset
from lab.description import ROBOTS_DIR, load_robot, shipped_robots
from lab.errors import InputError


@pytest.mark.parametrize("name", shipped_robots())
@pytest.mark.parametrize("method", DESIGNS)
def test_every_command_is_safe_and_deterministic(name, method):
    robot = load_robot(name)
    for n in (1, 7, 50):
        u = design_commands(robot, n, method, seed=2)
        assert u.shape == (n, robot.n_inputs)
        assert np.all(robot.is_safe(u)) and np.all(u >= robot.u_lower) and np.all(u <= robot.u_upper)
        assert np.array_equal(u, design_commands(robot, n, method, seed=2))
    assert not np.array_equal(design_commands(robot, 20, method, seed=0), design_commands(robot, 20, method, seed=1))


def test_a_tight_safety_rule_is_respected():
    robot = load_robot("three-cable")
    lim = dataclasses.replace(robot.safety_limits[0], max_sum_over_u_max=0.5)
    tight = dataclasses.replace(robot, safety_limits=(lim,))
    for method in DESIGNS:
        u = design_commands(tight, 40, method, seed=0)
        assert np.all(u.sum(axis=1) <= 0.5 * robot.u_max_rad + 1e-9)


@pytest.mark.parametrize("name", shipped_robots())
def test_maximin_spreads_further_than_random_and_sobol(name):
    robot = load_robot(name)
    for n in (5, 10, 30):
        for seed in (0, 1, 2):
            d = {m: min_distance(robot, design_commands(robot, n, m, seed=seed)) for m in DESIGNS}
            assert d["maximin"] > d["random"] and d["maximin"] > d["sobol"], (n, seed, d)


def test_bad_arguments():
    robot = load_robot("three-cable")
    for kwargs, words in [
        (dict(n=0, method="maximin"), "n >= 1"),
        (dict(n=-3, method="random"), "n >= 1"),
        (dict(n=2.5, method="sobol"), "n >= 1"),
        (dict(n=10**7, method="maximin"), "at most 2000"),
        (dict(n=10**7, method="random"), "at most 100000"),
        (dict(n=5, method="halton"), "unknown design 'halton'"),
        (dict(n=5, method="random", seed=-1), "seed"),
    ]:
        with pytest.raises(InputError, match=words):
            design_commands(robot, **kwargs)


def test_cli_choices_are_the_designs():
    import argparse

    sub = argparse.ArgumentParser().add_subparsers()
    p = add_parser(sub)
    action = next(a for a in p._actions if a.dest == "design")
    assert tuple(action.choices) == DESIGNS


def _coarse_robot(d):
    text = (ROBOTS_DIR / "three-cable.toml").read_text()
    (d / "coarse.toml").write_text(text.replace("n_rings = 3", "n_rings = 2").replace("n_axial = 20", "n_axial = 4"))


def test_capture_design_maximin_on_the_twin(tmp_path, capsys, monkeypatch):
    _coarse_robot(tmp_path)
    monkeypatch.chdir(tmp_path)
    args = ["capture", "--rig", "twin:random:3", "--robot", "coarse.toml", "--design", "maximin", "--n", "5"]
    args += ["--seed", "4", "--out", "real.csv", "--no-progress"]
    assert main(args) == 0
    u, y, meta = read_dataset(tmp_path / "real.csv")
    robot = load_robot(tmp_path / "coarse.toml")
    assert u.shape == (5, 3) and y.shape == (5, 3) and np.all(np.isfinite(y))
    assert np.array_equal(u, design_commands(robot, 5, "maximin", seed=4))  # rows in design order
    assert meta["sampler"]["name"] == "maximin" and meta["sampler"]["n"] == 5 and meta["sampler"]["seed"] == 4
    assert meta["rig"]["family"]["robot_seed"] == 3 and meta["rig"]["label"] == "emulated as-built robot"
    assert "--design maximin --n 5" in meta["command"] and "--grid" not in meta["command"]
    assert main(args) == 0 and "(0 new)" in capsys.readouterr().err  # resumes: nothing to capture


CAPTURE = ["capture", "--robot", "{dir}/robot.toml", "--out", "{dir}/c.csv", "--no-progress"]
NOT_WRITTEN = ("{dir}/c.csv", "{dir}/c.journal.csv")

#: Fault-sweep rows for the new capture arguments (format of tests/sweep.py).
CASES = [
    Case("design-without-n", [*CAPTURE, "--design", "sobol"], 2, ("needs the number", "--n N"), absent=NOT_WRITTEN),
    Case("n-without-design", [*CAPTURE, "--n", "5"], 2, ("--n N goes with --design",), absent=NOT_WRITTEN),
    Case("design-n-zero", [*CAPTURE, "--design", "maximin", "--n", "0"], 2, ("--n must be at least 1",)),
    Case(
        "design-n-too-large",
        [*CAPTURE, "--design", "maximin", "--n", "999999"],
        2,
        ("--design maximin --n 999999", "at most"),
        absent=NOT_WRITTEN,
    ),
    Case("design-negative-seed", [*CAPTURE, "--design", "random", "--n", "3", "--seed", "-1"], 2, ("--seed",)),
    # argparse's own errors exit from inside the parser: run these as programs
    Case(
        "design-and-grid",
        [*CAPTURE, "--design", "random", "--n", "3", "--grid", "3"],
        2,
        ("not allowed with",),
        subprocess=True,
    ),
    Case("design-unknown", [*CAPTURE, "--design", "halton", "--n", "3"], 2, ("invalid choice",), subprocess=True),
    Case(
        "design-out-is-robot",
        ["capture", "--robot", "{dir}/robot.toml", "--design", "sobol", "--n", "3", "--out", "{dir}/robot.toml"],
        2,
        ("is the input --robot",),
        unchanged=("{dir}/robot.toml",),
    ),
    # --lhs and --active (lab.cli.sampling) obey the same rules
    Case("lhs-and-grid", [*CAPTURE, "--lhs", "3", "--grid", "3"], 2, ("not allowed with",), subprocess=True),
    Case("active-and-sobol", [*CAPTURE, "--active", "6", "--sobol", "3"], 2, ("not allowed with",), subprocess=True),
    Case(
        "active-out-is-robot",
        ["capture", "--robot", "{dir}/robot.toml", "--active", "6", "--batch", "2", "--out", "{dir}/robot.toml"],
        2,
        ("is the input --robot",),
        unchanged=("{dir}/robot.toml",),
    ),
    Case(
        "active-journal-is-out",
        [*CAPTURE, "--active", "6", "--batch", "2", "--journal", "{dir}/c.csv"],
        2,
        ("is the same file as",),
        absent=NOT_WRITTEN,
    ),
    Case(
        "active-checkpoint-with-foreign-files",
        ["simulate", "--active", "6", "--batch", "2", "--checkpoint", "{dir}/mine", "--out", "{dir}/o.csv"],
        2,
        ("holds files that are not a lab checkpoint", "notes.txt", "nothing was deleted"),
        unchanged=("{dir}/mine/notes.txt",),
        absent=("{dir}/o.csv",),
        setup=lambda d: (d / "mine").mkdir() or (d / "mine" / "notes.txt").write_text("my notes"),
    ),
]


@pytest.mark.parametrize("case", CASES, ids=str)
def test_sweep_rows(case, tmp_path, capsys, monkeypatch):
    run_case(case, tmp_path, capsys, monkeypatch)


@pytest.mark.parametrize("name", ["three-cable", "six-cable"])
@pytest.mark.parametrize("method", ["maximin", "sobol", "random"])
def test_the_first_k_commands_are_the_same_whatever_the_design_length(name, method):
    # a transfer curve takes its rows at N from the first N commands of one long design: the
    # rows of every method at N must use the same samples as a design of N alone (a maximin
    # design's pool once grew with n, and its 308-point and 10-point designs shared no command)
    robot = load_robot(name)
    long = design_commands(robot, 308, method, seed=0)
    for k in (1, 5, 10, 100, 128, 129, 200):
        assert np.array_equal(long[:k], design_commands(robot, k, method, seed=0)), k


def test_a_latin_hypercube_is_not_prefix_stable():
    # its strata are n equal slices per motor: a design of 10 is no prefix of one of 50 (the docs say so)
    robot = load_robot("three-cable")
    assert not np.array_equal(design_commands(robot, 50, "lhs")[:10], design_commands(robot, 10, "lhs"))


def test_greedy_maximin_with_a_growing_pool():
    from lab.data.maximin import greedy_maximin

    rng = np.random.default_rng(3)
    x = rng.random((300, 3))
    # without n_candidates: every pick among all points, each the farthest from those picked
    picked = greedy_maximin(x, 7, 20)
    for k in range(1, 20):
        d = np.linalg.norm(x[:, None] - x[picked[:k]][None], axis=2).min(axis=1)
        assert picked[k] == int(np.argmax(d))

    # with it: the k-th pick the farthest among the first n_candidates(k) points, so a longer
    # selection starts with the shorter one
    def size(k):
        return 50 + 10 * k

    grown = greedy_maximin(x, 7, 20, n_candidates=size)
    for k in range(1, 20):
        d = np.linalg.norm(x[: size(k + 1), None] - x[grown[:k]][None], axis=2).min(axis=1)
        assert grown[k] == int(np.argmax(d)) and grown[k] < size(k + 1)
    assert grown[:8] == greedy_maximin(x, 7, 8, n_candidates=size)
    with pytest.raises(InputError, match="not among the 60 candidates"):
        greedy_maximin(x, 100, 5, n_candidates=size)
