"""Built-in target trajectories (shape, size, placement) and trajectory CSV files."""

import numpy as np
import pytest

from lab.control import trajectories as T


def yz(points):
    return points[:, 1:] - T.CENTRE_W[1:]


def test_circle():
    p = T.circle(64)
    assert p.shape == (64, 3)
    np.testing.assert_allclose(p[:, 0], T.CENTRE_W[0])  # in the plane x = const
    np.testing.assert_allclose(np.linalg.norm(yz(p), axis=1), 0.035)
    steps = np.linalg.norm(np.diff(np.vstack([p, p[:1]]), axis=0), axis=1)
    np.testing.assert_allclose(steps, steps[0])  # equally spaced, closed


def test_square():
    p = T.square(100, side_m=0.06)
    d = yz(p)
    np.testing.assert_allclose(np.max(np.abs(d), axis=1), 0.03)  # every point on the perimeter
    corners = {(sy, sz) for sy in (-0.03, 0.03) for sz in (-0.03, 0.03)}
    hits = {tuple(np.round(q, 12)) for q in d if np.allclose(np.abs(q), 0.03)}
    assert hits == corners  # n % 4 == 0 hits all corners
    steps = np.linalg.norm(np.diff(np.vstack([p, p[:1]]), axis=0), axis=1)
    np.testing.assert_allclose(steps, 0.24 / 100)
    np.testing.assert_allclose(np.ptp(p[:, 1:], axis=0), 0.06)  # 6 cm across


@pytest.mark.parametrize("k, petals", [(2, 4), (3, 3), (4, 8)])
def test_rose_petals(k, petals):
    p = T.rose(720, radius_m=0.035, k=k)
    r = np.linalg.norm(yz(p), axis=1)
    assert r.max() == pytest.approx(0.035, rel=1e-3) and r.min() < 1e-3  # through the centre
    tips = np.flatnonzero((r > np.roll(r, 1)) & (r >= np.roll(r, -1)) & (r > 0.03))
    assert len(tips) == petals
    with pytest.raises(T.TrajectoryError, match="positive integer"):
        T.rose(10, k=0)


def test_helix():
    p = T.helix(150, radius_m=0.03, turns=3, x_start_m=0.189, x_end_m=0.180)
    assert p[0, 0] == pytest.approx(0.189) and p[-1, 0] == pytest.approx(0.180)
    assert np.all(np.diff(p[:, 0]) < 0)
    np.testing.assert_allclose(np.linalg.norm(yz(p), axis=1), 0.03)
    angle = np.unwrap(np.arctan2(yz(p)[:, 1], yz(p)[:, 0]))
    assert angle[-1] - angle[0] == pytest.approx(3 * 2 * np.pi)


@pytest.mark.parametrize("name", T.BUILTIN)
def test_builtins_are_paper_sized(name):
    p = T.builtin(name)
    assert len(p) == T.DEFAULT_POINTS[name]
    across = np.ptp(p[:, 1:], axis=0).max()
    assert 0.059 <= across <= 0.10  # "around 6 cm to 10 cm across"
    assert np.all(np.isfinite(p))


def test_builtins_are_reachable_by_the_cached_model(three_cable):
    """Every target of every built-in is reachable through the shipped model."""
    from lab.control.command_set import CommandSet
    from lab.control.ik import IKSolver, grid_seeds
    from lab.learn.mlp import load_model

    model = load_model("data/model_sim_three_cable.npz")
    cs = CommandSet.from_robot(three_cable)
    solver = IKSolver(model, cs, seeds=grid_seeds(model, cs))
    for name in T.BUILTIN:
        assert solver.follow(T.builtin(name, 40)).reachable.all(), name


def test_csv_round_trip(tmp_path):
    p = T.rose(50)
    T.write_trajectory_csv(tmp_path / "rose.csv", p)
    assert (tmp_path / "rose.csv").read_text().splitlines()[0] == "x,y,z"
    np.testing.assert_array_equal(T.load_trajectory(tmp_path / "rose.csv"), p)
    np.testing.assert_array_equal(T.load_trajectory("square", 8), T.square(8))


@pytest.mark.parametrize(
    "text, message",
    [
        ("", "empty file"),
        ("x,y\n0.1,0.2\n", "header must be x,y,z"),
        ("x,y,z\n", "no points"),
        ("x,y,z\n0.1,0.2\n", "line 2 has 2 fields"),
        ("x,y,z\n0.1,0.0,0.0\n0.1,abc,0\n", "line 3 has a non-numeric value"),
        ("x,y,z\n0.1,nan,0\n", "line 2 has a NaN"),
        ("x,y,z\n184,0,-6\n", "must be in metres"),
    ],
)
def test_bad_csv_files(tmp_path, text, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(T.TrajectoryError, match=message):
        T.load_trajectory(path)


def test_bad_names_and_options(tmp_path):
    with pytest.raises(T.TrajectoryError, match="unknown trajectory 'star'.*circle, square, rose, helix"):
        T.load_trajectory("star")
    with pytest.raises(T.TrajectoryError, match="not found"):
        T.load_trajectory(tmp_path / "missing.csv")
    T.write_trajectory_csv(tmp_path / "c.csv", T.circle(5))
    with pytest.raises(T.TrajectoryError, match="built-in trajectories only"):
        T.load_trajectory(tmp_path / "c.csv", n_points=10)
    with pytest.raises(T.TrajectoryError, match="n_points"):
        T.circle(2)
    assert issubclass(T.TrajectoryError, ValueError)


def test_six_cable_paths_shapes():
    ring = T.builtin("six-ring")
    np.testing.assert_allclose(ring[:, 0], 0.165)
    np.testing.assert_allclose(np.linalg.norm(ring[:, 1:], axis=1), 0.07)
    saddle = T.builtin("six-saddle")
    assert saddle[:, 0].min() == pytest.approx(0.166) and saddle[:, 0].max() == pytest.approx(0.174)
    np.testing.assert_allclose(np.linalg.norm(saddle[:, 1:], axis=1), 0.06)
    spiral = T.builtin("six-spiral")
    assert np.linalg.norm(spiral[0, 1:]) == pytest.approx(0.01) and np.linalg.norm(spiral[-1, 1:]) == pytest.approx(
        0.08
    )
    assert spiral[0, 0] == pytest.approx(0.188) and spiral[-1, 0] == pytest.approx(0.160)
    assert len(T.load_trajectory("six-circle", 10)) == 10
    with pytest.raises(T.TrajectoryError, match="six-spiral"):
        T.builtin("seven-ring")


def test_six_cable_paths_need_the_second_stage_and_are_reachable_with_it():
    """Through the shipped six-cable model, with the regularised IK of notebook 06, every
    target is reached; with the short cables slack (first stage only) six-ring is not."""
    from lab.control.command_set import CommandSet
    from lab.control.ik import IKConfig, IKSolver, grid_seeds
    from lab.control.redundancy import FrozenMotors, frozen_commands
    from lab.description import load_robot
    from lab.learn.mlp import load_model

    six = load_robot("six-cable")
    model = load_model("data/model_sim_six_cable.npz")
    cs = CommandSet.from_robot(six)
    seeds = grid_seeds(model, cs, 4)
    solver = IKSolver(model, cs, IKConfig(reg_weight=1e-6, posture_weight=1e-6), seeds=seeds)
    for name in T.SIX_CABLE:
        tr = solver.follow(T.builtin(name))
        assert tr.reachable.all(), (name, int((~tr.reachable).sum()))
    first = FrozenMotors(model, [0, 1, 2], np.zeros(6))
    cs_first = frozen_commands(cs, [0, 1, 2], np.zeros(6))
    tr = IKSolver(first, cs_first, seeds=grid_seeds(first, cs_first, 9)).follow(T.builtin("six-ring"))
    assert (~tr.reachable).mean() > 0.5 and tr.residual_m.max() > 0.002
