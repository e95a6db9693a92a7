"""A cylinder with two interior markers from simulation to IK and ``track``, every marker observed.

Needs the bodies to give the description's ``[[markers]]`` (``fem.marker_names``) and the
dataset files to hold several markers (``read_dataset`` returning (N, 3K) with the sidecar's
``markers``).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from lab.cli import main
from lab.control import IKSolver
from lab.control.ik_config import IKConfig
from lab.control.trajectories import write_trajectory_csv
from lab.data import read_dataset, write_dataset
from lab.description import load_robot
from lab.fem.model import ArmFEM
from lab.fem.solve.statics import solve_static
from lab.jobs.train import TrainSpec
from lab.jobs.train import run as train
from lab.learn.outputs import output_markers
from lab.rig.sim import SimRig

ROBOTS = Path(__file__).resolve().parent.parent / "lab" / "robots"
MESH = {"n_rings": 1, "n_axial": 4}


def _robot(tmp_path) -> Path:
    src = (ROBOTS / "three-cable.toml").read_text()
    src += '\n[[markers]]\nname = "mid"\nposition_m = [0.10, 0.0, 0.0]\n'
    src += '\n[[markers]]\nname = "upper"\nposition_m = [0.15, 0.0, 0.01]\n'
    path = tmp_path / "marked.toml"
    path.write_text(src)
    return path


def test_simulated_markers_train_a_model_the_ik_drives(tmp_path):
    robot = load_robot(_robot(tmp_path))
    fem = ArmFEM(robot, **MESH)
    assert fem.marker_names == ("tip", "mid", "upper")
    u = np.random.default_rng(0).uniform(0.0, 1.5, (60, 3))
    q, y = fem.rest_q(), []
    for row in u:
        sol = solve_static(fem, row, q)
        q = sol.q
        y.append(np.asarray(sol.y_W).reshape(-1))
    y = np.array(y)
    write_dataset(tmp_path / "d.csv", u, y, {"markers": list(robot.marker_names), "robot": {"name": robot.name}})
    u_r, y_r, meta = read_dataset(tmp_path / "d.csv")
    assert y_r.shape == (60, 9) and meta["markers"] == ["tip", "mid", "upper"]
    run = train(TrainSpec(hidden=(10,), epochs=100), tmp_path / "d.csv")
    model = run.model
    assert output_markers(model) == ("tip", "mid", "upper") and model.predict(u[:2]).shape == (2, 9)
    model.save(tmp_path / "m.npz")
    for markers, rows in ((("tip",), slice(0, 3)), (("mid",), slice(3, 6))):
        solver = IKSolver.for_model(model, robot, IKConfig.automatic(markers=markers))
        target = model.predict(np.array([0.5, 0.7, 0.3]))[rows]
        res = solver.solve(target)
        assert robot.is_safe(res.u_motor)
        np.testing.assert_allclose(model.predict(res.u_motor)[rows], target, atol=1e-5)
    rig = SimRig(robot, fem)
    frame = rig.next_frame()
    assert frame.markers_W.shape == (3, 3)
    np.testing.assert_array_equal(frame.markers_W[0], frame.p_tip_W)
    tips = model.predict(np.array([[0.5, 0.7, 0.3], [0.6, 0.7, 0.3]]))[:, :3]
    write_trajectory_csv(tmp_path / "t.csv", tips)
    argv = ["track", "--robot", str(_robot(tmp_path)), "--model", str(tmp_path / "m.npz"), "--n-rings", "1",
            "--n-axial", "4", "--trajectory", str(tmp_path / "t.csv")]  # fmt: skip
    assert main([*argv, "--markers", "tip,mid", "--out", str(tmp_path / "r.json")]) == 0
    doc = json.loads((tmp_path / "r.json").read_text())
    assert doc["info"]["solver"]["markers"] == ["tip", "mid"] and len(doc["commands"]) == 2
