"""A user's own robot, not one the project ships, works end to end with the README's recipe
("A lab with its own robot") and default flags: ``simulate --sobol N``, ``train``, ``track --rig sim``.

The robot is ``examples/robots/four-cable.toml``: four cables in opposing pairs, so four
motors for a 3-D tip (redundant) and a slack cable opposite every pulled one. The mesh is
coarse (1 ring, 8 layers) to keep the test quick; data, model and simulated robot share it.
"""

import json
from pathlib import Path

import numpy as np
import pytest

from lab.cli import main
from lab.control.command_set import CommandSet
from lab.control.ik import IKConfig, IKSolver
from lab.control.soft_ik import FEMForwardMap
from lab.control.trajectories import circle, write_trajectory_csv
from lab.description import load_robot, shipped_robots
from lab.fem.model import ArmFEM

ROBOT = Path(__file__).resolve().parents[1] / "examples" / "robots" / "four-cable.toml"
MESH = ["--n-rings", "1", "--n-axial", "8"]
#: Sobol samples of the recipe: 250 per motor (measured: the smallest N where the default
#: training gives a model that tracks this path to <= 0.05 cm on this mesh).
N_SAMPLES = 1000


def path_targets():
    """60 targets on a circle of radius 2 cm in the plane x = 17 cm, about the arm's axis (the tip
    sags 4 mm at rest): inside the sampled tips (at x = 17 cm they reach 0-3.9 cm from the axis)."""
    return circle(60, radius_m=0.02, centre_W=[0.17, 0.0, -0.004])


def test_the_robot_is_new_and_redundant():
    robot = load_robot(ROBOT)
    assert robot.name not in shipped_robots() and robot.n_cables == 4
    for name in shipped_robots():
        shipped = load_robot(name)
        assert (robot.length_m, robot.radius_m) != (shipped.length_m, shipped.radius_m)
    solver = IKSolver(FEMForwardMap(ArmFEM(robot, n_rings=1, n_axial=8)), CommandSet.from_robot(robot), IKConfig("lm"))
    assert solver.redundant


def test_the_path_is_reachable_by_the_simulated_robot():
    """Soft IK on the FEM itself (no model) reaches a sample of the path: the targets are in
    the workspace, so any miss of the learned pipeline is the model's or the IK's."""
    robot = load_robot(ROBOT)
    fem = ArmFEM(robot, n_rings=1, n_axial=8)
    solver = IKSolver(FEMForwardMap(fem), CommandSet.from_robot(robot), IKConfig(reg_weight=None, posture_weight=None))
    plan = solver.follow(path_targets()[::10])
    assert plan.reachable.all(), plan.residual_m


@pytest.mark.slow  # 35-60 s: 1,000 FEM solves on two shared cores
def test_recipe_with_default_flags_tracks_to_half_a_millimetre(tmp_path):
    data, model, path, out = (tmp_path / n for n in ("data.csv", "model.npz", "path.csv", "track.json"))
    robot = str(ROBOT)
    assert (
        main(
            [
                "simulate",
                "--robot",
                robot,
                "--sobol",
                str(N_SAMPLES),
                *MESH,
                "--jobs",
                "1",
                "--no-progress",
                "--out",
                str(data),
            ]
        )
        == 0
    )
    assert main(["train", str(data), "--out", str(model)]) == 0
    write_trajectory_csv(path, path_targets())
    track = ["track", "--robot", robot, "--model", str(model), "--trajectory", str(path), "--rig", "sim", *MESH]
    assert main([*track, "--out", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert doc["n_unreachable"] == 0
    assert doc["mean_error_m"] <= 5e-4, f"mean tracking error {100 * doc['mean_error_m']:.4f} cm"
    sol = doc["info"]["solver"]
    assert sol["redundant"] and sol["regularisation"].startswith("auto: none while targets are reached")
    assert sol["restart_weight"] > 0 and sol["reg_weight_setting"] == sol["posture_weight_setting"] == "auto"
    assert np.isfinite(doc["timings"]["ik_per_target_mean_s"])


@pytest.mark.parametrize("flag", ["--reg-weight", "--posture-weight"])
def test_negative_weights_are_refused(tmp_path, capsys, flag):
    path = tmp_path / "p.csv"
    write_trajectory_csv(path, path_targets()[:3])
    args = ["track", "--robot", str(ROBOT), "--soft-ik", "--trajectory", str(path), *MESH, flag, "-1"]
    assert main([*args, "--out", str(tmp_path / "o.json")]) == 2
    err = capsys.readouterr().err  # names the flag (or, from Python, the field)
    assert "must be finite and >= 0" in err and (flag in err or flag[2:].replace("-", "_") in err), err
