"""Several markers through the models, the IK and ``track``; tension-controlled inputs in the IK.

A model predicts every marker of its data, the tip first, and records their names and its
input units (an older file reads as the tip alone, in rad); the IK drives the tip by
default and any marker or set of markers on request (``IKConfig.markers``); ``track
--markers`` moves the listed markers along the trajectory, each shifted by its rest offset
from the tip; a tension-controlled robot's IK stays within each tendon's ``tension_max_n``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from lab.cli import main
from lab.control import CommandSet, IKSolver
from lab.control.ik_config import IKConfig
from lab.control.markers import MarkerForward, marker_rows, select_markers
from lab.control.trajectories import write_trajectory_csv
from lab.description import load_robot
from lab.errors import InputError
from lab.fem.model import ArmFEM
from lab.fem.solve.statics import solve_static
from lab.learn.history import record_data_bounds
from lab.learn.metrics import mean_distance_m, workspace_size_m
from lab.learn.model_specs import model_spec
from lab.learn.models import fit_model, load_model
from lab.learn.outputs import dataset_io, input_units, output_markers, record_io
from lab.tracking.marker_targets import OffsetSolver, rest_offsets

MARKERS = ("tip", "mid", "base")
ROBOTS = Path(__file__).resolve().parent.parent / "lab" / "robots"


def _outputs(u):
    """Three smooth 'markers' (9 outputs) of commands u (N, 3): an invertible map per marker."""
    return np.hstack([0.1 * np.tanh(u), 0.05 * np.tanh(u[:, ::-1]) + 0.01, 0.02 * u + 0.005 * u**2])


@pytest.fixture(scope="module")
def data():
    u = np.random.default_rng(0).uniform(0.0, 1.0, (200, 3))
    return u, _outputs(u)


@pytest.fixture(scope="module")
def net(data):
    u, y = data
    model = fit_model(model_spec("mlp", hidden=(12,), epochs=200), u, y)
    record_io(model, MARKERS, ("rad", "N", "rad"))
    record_data_bounds(model, u)
    return model


@pytest.mark.parametrize("kind", ["mlp", "ensemble", "gpr", "knn", "sklearn-mlp", "inverse-mlp"])
def test_every_model_kind_fits_several_markers_and_names_them(kind, data, tmp_path):
    u, y = data[0][:60], data[1][:60]
    net = {"hidden": (5,), "epochs": 5}
    settings = {"mlp": net, "ensemble": {**net, "members": 2}, "inverse-mlp": net, "sklearn-mlp": {"hidden": (5,)}}
    settings = settings.get(kind, {})
    model = fit_model(model_spec(kind, **settings), u, y)
    record_io(model, MARKERS, ("rad", "N", "rad"))
    model.save(tmp_path / "m.npz")
    back = load_model(tmp_path / "m.npz")
    assert output_markers(back) == MARKERS and input_units(back, 3) == ("rad", "N", "rad")
    if kind == "inverse-mlp":
        assert back.command(y[:4]).shape == (4, 3)
    else:
        assert back.predict(u[:4]).shape == (4, 9)


def test_an_older_model_file_reads_as_the_tip_in_rad(data, tmp_path):
    u, y = data[0][:60], data[1][:60, :3]
    model = fit_model(model_spec("knn"), u, y)
    model.save(tmp_path / "old.npz")
    back = load_model(tmp_path / "old.npz")
    assert output_markers(back) == ("tip",) and input_units(back, 3) == ("rad",) * 3


def test_a_datasets_markers_and_units_come_from_its_sidecar():
    assert dataset_io({}, 3, 3) == (("tip",), ("rad",) * 3)
    assert dataset_io({"markers": list(MARKERS), "input_units": ["N", "N", "rad"]}, 3, 9) == (
        MARKERS,
        ("N", "N", "rad"),
    )
    assert dataset_io({"robot": {"u_unit": "N"}}, 2, 3)[1] == ("N", "N")
    with pytest.raises(InputError, match="need 9 output columns, got 6"):
        dataset_io({"markers": list(MARKERS)}, 3, 6, "d.csv")


def test_errors_and_workspace_count_every_marker_and_the_tip():
    y = np.zeros((2, 6))
    y_hat = y + np.array([[3.0, 4.0, 0.0, 0.0, 0.0, 1.0]])
    assert mean_distance_m(y_hat, y) == pytest.approx(3.0)  # (5 + 1) / 2 per point
    assert mean_distance_m(y_hat[:, :3], y[:, :3]) == pytest.approx(5.0)
    assert workspace_size_m(np.array([[0, 0, 0, 9, 9, 9], [1, 0, 0, -9, 9, 9]], float)) == 1.0


def test_the_ik_drives_the_tip_by_default_and_any_marker_on_request(net):
    bounds = (np.zeros(3), np.ones(3))
    u_true = np.array([0.3, 0.6, 0.4])
    y = net.predict(u_true)
    tip = IKSolver.for_model(net, bounds=bounds)
    assert tip.n_tip == 3 and isinstance(tip.forward, MarkerForward)
    res = tip.solve(y[:3])
    np.testing.assert_allclose(net.predict(res.u_motor)[:3], y[:3], atol=1e-6)
    for markers in (("mid",), ("base", "tip")):
        solver = IKSolver.for_model(net, config=IKConfig.automatic(markers=markers), bounds=bounds)
        rows = marker_rows(MARKERS, markers)
        assert solver.n_tip == 3 * len(markers)
        res = solver.solve(y[rows])
        np.testing.assert_allclose(net.predict(res.u_motor)[rows], y[rows], atol=1e-6)
        yj, J = solver.forward.predict_and_jacobian(u_true)
        np.testing.assert_array_equal(J, net.predict_and_jacobian(u_true)[1][rows])
    every = IKSolver.for_model(net, config=IKConfig.automatic(markers=MARKERS), bounds=bounds)
    assert every.forward is net
    with pytest.raises(InputError, match=r"\['elbow'\] not among the markers .*'tip', 'mid', 'base'"):
        IKSolver.for_model(net, config=IKConfig.automatic(markers=("elbow",)), bounds=bounds)
    with pytest.raises(InputError, match=r"targets must be \(6,\)"):
        IKSolver.for_model(net, config=IKConfig.automatic(markers=("tip", "mid")), bounds=bounds).solve(y[:3])


def test_marker_names_in_the_config():
    assert IKConfig().markers == ("tip",)
    assert IKConfig(markers="tip, mid").markers == ("tip", "mid")
    for bad in ("", "tip,tip", ()):
        with pytest.raises(InputError, match="markers must be distinct marker names"):
            IKConfig(markers=bad)
    with pytest.raises(InputError, match="predicts 6 outputs, but the targets have 3 columns"):
        select_markers(type("M", (), {"n_y": 6, "metadata": {}})(), ("tip",))


def test_a_trajectory_moves_the_markers_by_their_rest_offsets(net):
    bounds = (np.zeros(3), np.ones(3))
    solver = IKSolver.for_model(net, config=IKConfig.automatic(markers=("tip", "mid")), bounds=bounds)
    offsets = rest_offsets(net, ("tip", "mid"), np.zeros(3))
    rest = net.predict(np.zeros(3))
    np.testing.assert_allclose(offsets, [np.zeros(3), rest[3:6] - rest[:3]])
    follow = OffsetSolver(solver, offsets)
    tips = net.predict(np.zeros((2, 3)))[:, :3] + [[0.0, 0.0, 0.0], [1e-4, 0.0, 0.0]]
    plan = follow.follow(tips)
    assert plan.p_pred_W.shape == (2, 3) and plan.info["markers"] == ["tip", "mid"]
    np.testing.assert_array_equal(follow.expand(tips)[:, 3:], tips + offsets[1])


def _tension_robot(tmp_path, markers=()) -> Path:
    """three-cable with every cable pulled by tension (at most 2 N), no spool, no safety rule."""
    src = (ROBOTS / "three-cable.toml").read_text()
    for name in ("top", "lower-left", "lower-right"):
        src = src.replace(f'name = "{name}"', f'name = "{name}"\ncontrol = "tension"\ntension_max_n = 2.0')
    src = src[: src.index("[[safety.limits]]")]
    src = src[: src.index("[actuation]")] + src[src.index("[[cables]]") :]
    for name, x in markers:
        src += f'\n[[markers]]\nname = "{name}"\nposition_m = [{x}, 0.0, 0.0]\n'
    path = tmp_path / "tension.toml"
    path.write_text(src)
    return path


def test_a_tension_robots_soft_ik_stays_within_its_tensions(tmp_path):
    robot = load_robot(_tension_robot(tmp_path))
    commands = CommandSet.from_robot(robot)
    np.testing.assert_array_equal(commands.lo, [0, 0, 0])
    np.testing.assert_array_equal(commands.hi, [2.0, 2.0, 2.0])
    fem = ArmFEM(robot, n_rings=1, n_axial=4)
    u_true = np.array([1.2, 0.4, 0.1])
    target = solve_static(fem, u_true).p_tip_W
    solver = IKSolver.for_model(None, robot, fem=fem)
    res = solver.solve(target)
    assert np.all(res.u_motor >= 0) and np.all(res.u_motor <= 2.0)
    assert robot.is_safe(res.u_motor)
    assert np.linalg.norm(solve_static(fem, res.u_motor).p_tip_W - target) < 1e-5
    far = solver.solve(target + [0.0, 0.0, 0.5])  # out of reach: pushed to the bounds, not beyond
    assert np.all(far.u_motor >= -1e-12) and np.all(far.u_motor <= 2.0 + 1e-12)


def test_track_without_a_rig_drives_the_named_markers(net, tmp_path):
    net.save(tmp_path / "m.npz")
    tips = net.predict(np.array([[0.2, 0.3, 0.4], [0.25, 0.3, 0.4]]))[:, :3]
    write_trajectory_csv(tmp_path / "t.csv", tips)
    argv = ["track", "--rig", "none", "--model", str(tmp_path / "m.npz"), "--trajectory", str(tmp_path / "t.csv")]
    assert main([*argv, "--markers", "tip,mid", "--out", str(tmp_path / "r.json")]) == 0
    doc = json.loads((tmp_path / "r.json").read_text())
    u = np.array(doc["commands"])
    assert u.shape == (2, 3) and np.all(u >= 0) and np.all(u <= 1)
    assert main([*argv, "--out", str(tmp_path / "tip.json")]) == 0
    tip_u = np.array(json.loads((tmp_path / "tip.json").read_text())["commands"])
    np.testing.assert_allclose(net.predict(tip_u)[:, :3], tips, atol=1e-5)
    assert main([*argv, "--markers", "elbow", "--out", str(tmp_path / "bad.json")]) == 2
