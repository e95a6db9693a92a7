"""``capture`` and ``transfer`` of a robot with markers, through the command line in-process.

A cylinder robot with two interior ``[[markers]]`` (the three-cable arm plus markers, in
tmp_path) captured on a coarse twin writes every marker (``x,y,z,mid_x,...``, sidecar
``markers``); ``transfer`` takes that dataset with every data method (here: real-only and
residual) and refuses simulated data of other markers. A robot with a tension-controlled
tendon is captured with its input in N.
"""

from pathlib import Path

import numpy as np
import pytest

import lab
from lab.asbuilt.arm import default_defects_path
from lab.cli import main
from lab.data.dataset import read_dataset, write_dataset

MARKERS = """
[[markers]]
name = "mid"
position_m = [0.10, 0.0, 0.004]

[[markers]]
name = "ring"
position_m = [0.15, 0.006, 0.0]
"""


def _robot(tmp_path, name, tension=False) -> Path:
    text = (Path(lab.__file__).parent / "robots" / "three-cable.toml").read_text() + MARKERS
    if tension:
        text = text.replace('name = "top"\n', 'name = "top"\ncontrol = "tension"\ntension_max_n = 2.0\n', 1)
        text = text.replace("cables = [0, 1, 2]", "cables = [1, 2]")
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def coarse_defects(three_cable, tmp_path_factory):
    path = tmp_path_factory.mktemp("defects") / "coarse.toml"
    path.write_text(
        default_defects_path(three_cable)
        .read_text()
        .replace("# [emulator]", "[emulator]")
        .replace("# n_rings = 1", "n_rings = 2")
        .replace("# n_axial = 6", "n_axial = 4")
    )
    return path


def _capture(robot, defects, out, *extra):
    args = ["capture", "--robot", str(robot), "--rig", f"twin:{defects}", "--out", str(out), "--no-progress"]
    return main([*args, "--seed", "3", *extra])


def test_capture_then_transfer_every_marker(coarse_defects, tmp_path, capsys):
    robot = _robot(tmp_path, "markers.toml")
    out = tmp_path / "real.csv"
    assert _capture(robot, coarse_defects, out, "--grid", "2") == 0
    u, y, meta = read_dataset(out)
    assert y.shape == (len(u), 9) and meta["markers"] == ["tip", "mid", "ring"]
    assert out.read_text().splitlines()[0] == "u0,u1,u2,x,y,z,mid_x,mid_y,mid_z,ring_x,ring_y,ring_z"
    assert np.all(y[:, 3] < y[:, 6]) and np.all(y[:, 6] < y[:, 0])  # mid, ring, tip along the arm
    capsys.readouterr()
    model = tmp_path / "real_only.npz"
    assert (
        main(["transfer", "--method", "real-only", "--real", str(out), "--robot", str(robot), "--out", str(model)]) == 0
    )
    line = capsys.readouterr().out.strip().splitlines()[-1]
    assert '"fit_mean_distance_mm"' in line
    from lab.learn.mlp import load_model

    assert load_model(model).n_y == 9
    # a simulated dataset of the same markers: residual on top of its network
    sim = tmp_path / "sim.csv"
    rng = np.random.default_rng(0)
    u_sim = rng.uniform(0, 1.5, (40, 3))
    y_sim = np.hstack([np.tile(y.mean(axis=0), (40, 1)) + 0.01 * u_sim @ rng.normal(size=(3, 9))])
    write_dataset(sim, u_sim, y_sim, {"robot": {"name": "three-cable"}}, markers=("tip", "mid", "ring"))
    args = ["transfer", "--method", "residual", "--real", str(out), "--sim", str(sim), "--robot", str(robot)]
    assert main([*args, "--hidden", "4", "--out", str(tmp_path / "res.npz")]) == 0
    # simulated data of the tip alone does not go with real data of three markers
    tip = tmp_path / "tip.csv"
    write_dataset(tip, u_sim, y_sim[:, :3], {"robot": {"name": "three-cable"}})
    args = ["transfer", "--method", "finetune", "--real", str(out), "--sim", str(tip), "--robot", str(robot)]
    assert main([*args, "--out", str(tmp_path / "ft.npz")]) == 2
    assert "simulate the same markers" in capsys.readouterr().err


def test_capture_a_tension_robot_in_newtons(coarse_defects, tmp_path):
    robot = _robot(tmp_path, "tension.toml", tension=True)
    out = tmp_path / "tension.csv"
    assert _capture(robot, coarse_defects, out, "--sobol", "4") == 0
    u, y, meta = read_dataset(out)
    assert meta["input_units"] == ["N", "rad", "rad"] and y.shape == (4, 9)
    assert np.all(u[:, 0] <= 2.0) and np.all(u[:, 1:] <= 3.0)


def test_calibrated_transfer_fits_and_retrains_on_the_datas_markers(tmp_path):
    from lab.description import load_robot
    from lab.fem.model import ArmFEM
    from lab.rig.sim import SimRig
    from lab.transfer.calibrated import calibrated_model

    robot = load_robot(_robot(tmp_path, "markers.toml"))
    rig = SimRig(robot, ArmFEM(robot, n_rings=1, n_axial=4))
    u = np.random.default_rng(1).uniform(0.0, 1.5, (12, 3))
    y = []
    for ui in u:
        rig.send(ui)
        y.append(rig.next_frame().markers_W[[0, 2]].ravel())  # the tip and "ring", in that order
    model = calibrated_model(
        robot, u, np.array(y), u[:10], hidden=(3,), n_rings=1, n_axial=4, max_iter=2, markers=("tip", "ring")
    )
    assert model.n_y == 6 and model.metadata["transfer"]["markers"] == ["tip", "ring"]
