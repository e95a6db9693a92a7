"""Fault-sweep rows (tests/sweep.py format) for ``track --rig none``: the IK's commands for a
lab's own robot, from the model alone (lab.tracking.offline).

``model.npz`` is the shipped three-cable model (trained on a shipped robot's data, no data
bounds recorded: the robot's allowed commands); the setups below write small random
networks of a "measured" robot (``trunk.npz``: 6 motors, negative commands, data bounds in
its metadata) and of wrong shapes.
"""

import shutil
from pathlib import Path

import numpy as np
from sweep import Case

ROOT = Path(__file__).resolve().parent.parent
NONE = ["track", "--rig", "none", "--model", "{dir}/model.npz", "--trajectory", "{dir}/traj.csv"]
OUT = ["--out", "{dir}/r.json"]
INPUTS = ("{dir}/model.npz", "{dir}/traj.csv")
ABSENT = ("{dir}/r.json", "{dir}/r.json.commands.csv")


def _net(path: Path, n_u: int, n_y: int, metadata: dict) -> None:
    from lab.learn.mlp import MLP

    rng = np.random.default_rng(n_u + 10 * n_y)
    lo, hi = np.full(n_u, -3.0), np.full(n_u, -0.5)
    MLP([rng.normal(0, 0.5, (4, n_u)), rng.normal(0, 0.5, (n_y, 4))], [np.zeros(4), np.zeros(n_y)], lo, hi,
        np.full(n_y, -0.05), np.full(n_y, 0.05), metadata=metadata).save(path)  # fmt: skip


def _measured(n_u: int = 6, n_y: int = 3, bounds: bool = True, name: str = "trunk.npz"):
    def setup(d: Path):
        meta = {"training": {"data": {"robot": "trunk"}}}
        if bounds:
            meta["data_bounds"] = {"u_min": [-3.0] * n_u, "u_max": [-0.5] * n_u}
        _net(d / name, n_u, n_y, meta)

    return setup


def _write(name: str, text: str):
    def setup(d: Path):
        (d / name).write_text(text)

    return setup


def _inverse(d: Path):
    from lab.learn.inverse import InverseModel
    from lab.learn.mlp import MLP

    net = MLP([np.zeros((2, 3)), np.zeros((3, 2))], [np.zeros(2), np.zeros(3)], -np.ones(3), np.ones(3),
              np.zeros(3), np.full(3, 3.0))  # fmt: skip
    InverseModel(net, np.zeros(3), np.full(3, 3.0)).save(d / "inverse.npz")


def _wrote_commands(d: Path):
    import json

    doc = json.loads((d / "r.json").read_text())
    rows = np.loadtxt(d / "r.json.commands.csv", delimiter=",", skiprows=1, ndmin=2)
    header = (d / "r.json.commands.csv").read_text().splitlines()[0]
    assert header == "u0,u1,u2,x_pred,y_pred,z_pred,error_m", header
    assert doc["kind"] == "lab.track.commands" and doc["rig"] == "none" and doc["history"] == 0
    np.testing.assert_array_equal(rows[:, :3], np.array(doc["commands"]))
    assert not (d / "r.json.points.csv").exists()


def _wrote_over_the_earlier_run(d: Path):
    header = (d / "r.json.commands.csv").read_text().splitlines()[0]
    assert header == "u0,u1,u2,x_pred,y_pred,z_pred,error_m", header


_TRUNK = ["track", "--rig", "none", "--model", "{dir}/trunk.npz", "--trajectory", "{dir}/path.csv", *OUT]
_PATH = _write("path.csv", "x,y,z\n0.01,0.0,0.0\n0.0,0.01,0.0\n")

RIG_NONE_CASES: list = [
    Case("rig-none-shipped-model", [*NONE, *OUT], 0, ("no rig", "r.json.commands.csv"), INPUTS, after=_wrote_commands),
    Case(
        "rig-none-measured-model",
        _TRUNK,
        0,
        ("2 targets solved",),
        ("{dir}/trunk.npz", "{dir}/path.csv"),
        setup=lambda d: (_measured()(d), _PATH(d)),
    ),
    Case(
        "rig-none-soft-ik",
        ["track", "--rig", "none", "--soft-ik", "--trajectory", "{dir}/traj.csv", *OUT],
        2,
        ("--soft-ik is not used with --rig none", "solves through --model"),
        INPUTS,
        ABSENT,
    ),
    Case(
        "rig-none-closed-loop",
        [*NONE, "--closed-loop", "ilc", "--passes", "2", *OUT],
        2,
        ("--closed-loop, --passes are not used with --rig none", "nothing is measured"),
        INPUTS,
        ABSENT,
    ),
    Case("rig-none-gain", [*NONE, "--gain", "0.5", *OUT], 2, ("--gain is not used with --rig none",), INPUTS, ABSENT),
    Case(
        "rig-none-period",
        [*NONE, "--period-s", "5", *OUT],
        2,
        ("--period-s is not used with --rig none", "OUT.commands.csv"),
        INPUTS,
        ABSENT,
    ),
    Case(
        "rig-none-streaming-flag",
        [*NONE, "--n-periods", "3", *OUT],
        2,
        ("--n-periods is not used with --rig none",),
        INPUTS,
        ABSENT,
    ),
    Case(
        "rig-none-seed",
        [*NONE, "--seed", "3", *OUT],
        2,
        ("--seed is not used with --rig none", "noise"),
        INPUTS,
        ABSENT,
    ),
    Case(
        "rig-none-mesh",
        [*NONE, "--n-rings", "1", *OUT],
        2,
        ("--n-rings is not used with --rig none", "FEM"),
        INPUTS,
        ABSENT,
    ),
    Case(
        "rig-none-robot",
        [*NONE, "--robot", "six-cable", *OUT],
        2,
        ("--robot is not used with --rig none", "training data"),
        INPUTS,
        ABSENT,
    ),
    Case(
        "rig-none-argument",
        ["track", "--rig", "none:x", *NONE[3:], *OUT],
        2,
        ("rig 'none' takes no argument",),
        INPUTS,
        ABSENT,
    ),
    Case(
        "rig-none-other-command",
        ["capture", "--rig", "none", "--grid", "2", "--out", "{dir}/c.csv"],
        2,
        ("--rig none (no rig) is taken by `track` only",),
        (),
        ("{dir}/c.csv",),
    ),
    Case(
        "rig-none-target-nan",
        [*_TRUNK],
        2,
        ("path.csv: line 3 has a NaN",),
        ("{dir}/path.csv",),
        ABSENT,
        setup=lambda d: (_measured()(d), _write("path.csv", "x,y,z\n0.01,0,0\nnan,0,0\n")(d)),
    ),
    Case(
        "rig-none-target-header",
        [*_TRUNK],
        2,
        ("path.csv: header must be x,y,z",),
        ("{dir}/path.csv",),
        ABSENT,
        setup=lambda d: (_measured()(d), _write("path.csv", "x,y\n0.01,0\n")(d)),
    ),
    Case(
        "rig-none-target-millimetres",
        [*_TRUNK],
        2,
        ("millimetres or centimetres",),
        ("{dir}/path.csv",),
        ABSENT,
        setup=lambda d: (_measured()(d), _write("path.csv", "x,y,z\n10,200,-30\n")(d)),
    ),
    Case(
        "rig-none-target-missing",
        [*_TRUNK[:-3], "{dir}/gone.csv", *OUT],
        2,
        ("gone.csv",),
        (),
        ABSENT,
        setup=_measured(),
    ),
    Case(
        "rig-none-builtin-for-measured-model",
        [*_TRUNK[:-3], "circle", *OUT],
        2,
        ("built-in trajectories are in the shipped arms' frames", "three-cable arm's", "header x,y,z"),
        ("{dir}/trunk.npz",),
        ABSENT,
        setup=_measured(),
    ),
    Case(
        "rig-none-model-two-outputs",
        _TRUNK,
        2,
        ("predicts 2 outputs", "3 columns (x, y, z)"),
        ("{dir}/trunk.npz",),
        ABSENT,
        setup=lambda d: (_measured(n_y=2)(d), _PATH(d)),
    ),
    Case(
        "rig-none-model-without-bounds",
        _TRUNK,
        2,
        ("records no bounds of its training data",),
        ("{dir}/trunk.npz",),
        ABSENT,
        setup=lambda d: (_measured(bounds=False)(d), _PATH(d)),
    ),
    Case(
        "rig-none-inverse-model",
        [*NONE[:4], "{dir}/inverse.npz", *NONE[5:], *OUT],
        2,
        ("direct inverse model",),
        ("{dir}/inverse.npz", "{dir}/traj.csv"),
        ABSENT,
        setup=_inverse,
    ),
    Case("rig-none-out-is-model", [*NONE, "--out", "{dir}/model.npz"], 2, ("is the input --model",), INPUTS),
    Case("rig-none-out-is-trajectory", [*NONE, "--out", "{dir}/traj.csv"], 2, ("is the input --trajectory",), INPUTS),
    Case(
        "rig-none-commands-file-is-model",
        [*NONE[:4], "{dir}/m.commands.csv", *NONE[5:], "--out", "{dir}/m"],
        2,
        ("--out commands {dir}/m.commands.csv is the input --model",),
        ("{dir}/m.commands.csv",),
        setup=lambda d: shutil.copy(d / "model.npz", d / "m.commands.csv"),
    ),
    Case(
        "rig-none-commands-file-of-the-user",
        [*NONE, *OUT],
        2,
        ("commands file {dir}/r.json.commands.csv exists and is not one this program wrote", "nothing was changed"),
        (*INPUTS, "{dir}/r.json.commands.csv"),
        ("{dir}/r.json",),
        setup=_write("r.json.commands.csv", "my notes on the robot\n"),
    ),
    Case(
        "rig-none-commands-file-a-directory",
        [*NONE, *OUT],
        2,
        ("commands file {dir}/r.json.commands.csv exists and is not a file",),
        INPUTS,
        ("{dir}/r.json",),
        setup=lambda d: (d / "r.json.commands.csv").mkdir(),
    ),
    Case(
        "rig-none-commands-file-of-an-earlier-run",
        [*NONE, *OUT],
        0,
        ("no rig", "commands -> {dir}/r.json.commands.csv"),
        INPUTS,
        setup=_write(
            "r.json.commands.csv", "u0,u1,u2,u3,u4,u5,x_pred,y_pred,z_pred,error_m,spread_m\n1,2,3,4,5,6,0,0,0,0,0\n"
        ),
        after=_wrote_over_the_earlier_run,
    ),
    Case(
        "rig-none-target-bom-crlf",
        _TRUNK,
        0,
        ("2 targets solved", "IK residual through the model"),
        ("{dir}/trunk.npz", "{dir}/path.csv"),
        setup=lambda d: (
            _measured()(d),
            (d / "path.csv").write_bytes(b"\xef\xbb\xbfx,y,z\r\n0.01,0.0,0.0\r\n0.0,0.01,0.0\r\n"),
        ),
    ),
    Case("rig-none-out-is-a-directory", [*NONE, "--out", "{dir}"], 2, ("is a directory",), INPUTS),
    Case(
        "rig-none-n-points-huge",
        [*NONE[:-1], "circle", "--n-points", "100000000", *OUT],
        2,
        ("--n-points",),
        INPUTS,
        ABSENT,
    ),
]
