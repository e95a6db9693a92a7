"""Running a trajectory on a rig (settling, sim robot), the result file, the ``track`` CLI, Table I."""

import json

import numpy as np
import pytest

from lab.cli import main
from lab.control.command_set import CommandSet
from lab.control.ik import IKSolver
from lab.control.soft_ik import FEMForwardMap
from lab.control.trajectories import circle, write_trajectory_csv
from lab.data.dataset import read_dataset
from lab.fem.solve.statics import solve_static
from lab.rig.base import MocapFrame, Rig, RigError
from lab.rig.sim import SimRig
from lab.studies import table1
from lab.tracking.track import REQUIRED_KEYS, read_result, run_trajectory, write_result


class LaggingRig(Rig):
    """An emulated arm whose tip follows ``p = c + B u`` with a first-order lag (time
    constant 0.3 s) and 0.05 mm motion-capture noise, at 120 Hz; motors move instantly."""

    kind = "lagging"

    def __init__(self, robot, c, B):
        super().__init__(robot, 120.0)
        self.c, self.B, self.t, self.noise = c, B, 0.0, np.random.default_rng(0)
        self.u, self.p_from, self.t_cmd = np.zeros(3), c.copy(), 0.0

    def _tip(self, t):
        goal = self.c + self.B @ self.u
        return goal + (self.p_from - goal) * np.exp(-(t - self.t_cmd) / 0.3)

    def _send(self, u):
        self.p_from, self.u, self.t_cmd = self._tip(self.t), u.copy(), self.t

    def present_u(self):
        return self.u.copy()

    def now(self):
        return self.t

    def next_frame(self):
        self.t += 1 / 120
        return MocapFrame(self.t, self._tip(self.t) + 5e-5 * self.noise.standard_normal(3))


class Linear:
    """Forward map p = c + B u (exact for the LaggingRig once settled)."""

    def __init__(self, c, B):
        self.c, self.B = c, B

    def predict_and_jacobian(self, u):
        return self.c + self.B @ u, self.B.copy()


def test_tracking_waits_for_a_lagging_tip(three_cable):
    """Each point is recorded by the capture protocol's settle rule, not right after the command."""
    c, B = np.array([0.2, 0.0, -0.01]), 0.01 * np.array([[-0.1, -0.1, -0.1], [0.0, -1.0, 1.0], [1.0, -0.5, -0.5]])
    targets = c + np.array([B @ u for u in ([1.0, 0.5, 0.5], [1.2, 0.4, 0.9], [0.5, 1.5, 0.3])])
    solver = IKSolver(Linear(c, B), CommandSet.from_robot(three_cable))
    with LaggingRig(three_cable, c, B) as rig:
        res = run_trajectory(rig, solver, targets)
    assert res.settled.all() and np.all(res.settle_wait_s >= 2.0)  # 20 readings of 0.1 s before
    assert res.max_error_m < 1e-4  # vs ~5 mm steps between targets


def test_soft_ik_tracks_the_sim_robot_exactly(three_cable, coarse_fem):
    """Soft IK on the same FEM as the sim rig: the achieved tips are the targets, and the
    recorded tips are what an independent static solve gives for each command."""
    targets = circle(8, radius_m=0.02, centre_W=[0.185, 0.0, -0.008])
    solver = IKSolver(FEMForwardMap(coarse_fem), CommandSet.from_robot(three_cable))
    with SimRig(three_cable, coarse_fem) as rig:
        res = run_trajectory(rig, solver, targets, name="small circle")
    assert res.reachable.all()
    assert res.max_error_m < 1e-6
    for u, p in zip(res.commands[::3], res.achieved_W[::3]):
        np.testing.assert_allclose(solve_static(coarse_fem, u).p_tip_W, p, atol=1e-8)
    np.testing.assert_allclose(res.errors_m, np.linalg.norm(res.achieved_W - targets, axis=1))
    assert res.mean_error_m == pytest.approx(res.errors_m.mean())
    assert res.settled.all() and res.timings["ik_per_target_mean_s"] > 0


@pytest.fixture(scope="module")
def model_file(tmp_path_factory):
    from lab.learn.train import train

    u, y, _ = read_dataset("data/sim_three_cable.csv")
    path = tmp_path_factory.mktemp("model") / "tiny.npz"
    train(u, y, (6,), seed=0, epochs=20).model.save(path)
    return path


COARSE = ["--n-rings", "1", "--n-axial", "6"]


def test_track_cli_end_to_end(model_file, tmp_path):
    out = tmp_path / "circle.json"
    assert (
        main(
            [
                "track",
                "--model",
                str(model_file),
                "--rig",
                "sim",
                "--robot",
                "three-cable",
                "--trajectory",
                "circle",
                "--n-points",
                "5",
                *COARSE,
                "--out",
                str(out),
            ]
        )
        == 0
    )
    doc = json.loads(out.read_text())
    assert set(REQUIRED_KEYS) <= set(doc)
    assert np.shape(doc["targets"]) == (5, 3) and np.shape(doc["commands"]) == (5, 3)
    assert np.shape(doc["achieved"]) == (5, 3) and len(doc["errors_m"]) == 5
    err = np.linalg.norm(np.array(doc["achieved"]) - doc["targets"], axis=1)
    np.testing.assert_allclose(doc["errors_m"], err)
    assert doc["mean_error_m"] == pytest.approx(err.mean()) and doc["max_error_m"] == pytest.approx(err.max())
    assert {"ik_total_s", "ik_per_target_mean_s"} <= set(doc["timings"])
    assert "track" in doc["info"]["command"]
    assert read_result(out)["targets"].shape == (5, 3)

    csv = tmp_path / "two.csv"
    write_trajectory_csv(csv, circle(4)[:2])
    assert main(["track", "--soft-ik", "--trajectory", str(csv), *COARSE, "--out", str(tmp_path / "s.json")]) == 0
    assert len(json.loads((tmp_path / "s.json").read_text())["targets"]) == 2


def test_track_cli_six_cable_regularised(tmp_path):
    """The redundant arm through the shipped six-cable model: every target reached by the IK,
    the regulariser recorded, motor steps small between neighbouring targets."""
    out = tmp_path / "spiral.json"
    assert (
        main(
            [
                "track",
                "--model",
                "data/model_sim_six_cable.npz",
                "--robot",
                "six-cable",
                "--trajectory",
                "six-spiral",
                "--n-points",
                "12",
                "--reg-weight",
                "1e-6",
                "--posture-weight",
                "1e-6",
                *COARSE,
                "--out",
                str(out),
            ]
        )
        == 0
    )
    doc = json.loads(out.read_text())
    assert np.shape(doc["commands"]) == (12, 6) and doc["n_unreachable"] == 0
    assert max(doc["ik_residual_m"]) < 1e-8  # polished: no regulariser bias
    solver = doc["info"]["solver"]
    assert solver["reg_weight"] == 1e-6 and solver["posture_weight"] == 1e-6 and solver["polish"]
    assert solver["u_posture"] == [1.5] * 6


@pytest.mark.parametrize(
    "args, message",
    [
        (["--trajectory", "star"], "unknown trajectory"),
        (["--trajectory", "circle", "--model", "missing.npz"], "not found"),
        (["--trajectory", "circle", "--robot", "six-cable"], "6 cables"),
        (["--trajectory", "circle", "--rig", "hardware"], "configuration file"),
        (["--trajectory", "circle", "--rig", "twin", *COARSE], "mesh of --rig sim"),
    ],
)
def test_track_cli_bad_input(model_file, tmp_path, capsys, args, message):
    base = [] if "--model" in args else ["--model", str(model_file)]
    assert main(["track", *base, *args, "--n-points", "4", "--out", str(tmp_path / "r.json")]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "r.json").exists()


def test_rig_is_closed_on_errors(model_file, tmp_path, monkeypatch, capsys):
    closed = []
    monkeypatch.setattr(SimRig, "_close", lambda self: closed.append(True))

    def fail(*args, **kwargs):
        raise RigError("servo 2 stopped answering")

    monkeypatch.setattr("lab.tracking.track.measure", fail)
    assert (
        main(
            [
                "track",
                "--model",
                str(model_file),
                "--trajectory",
                "circle",
                "--n-points",
                "3",
                *COARSE,
                "--out",
                str(tmp_path / "r.json"),
            ]
        )
        == 1
    )
    assert closed == [True] and "servo 2" in capsys.readouterr().err

    def boom(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr("lab.tracking.track.measure", boom)
    # Ctrl-C: the rig is closed, a clean message, exit code 130 (no KeyboardInterrupt traceback)
    assert (
        main(
            [
                "track",
                "--model",
                str(model_file),
                "--trajectory",
                "circle",
                "--n-points",
                "3",
                *COARSE,
                "--out",
                str(tmp_path / "r.json"),
            ]
        )
        == 130
    )
    assert closed == [True, True] and "interrupted" in capsys.readouterr().err


def test_result_file_nan_and_errors(tmp_path, three_cable, coarse_fem):
    from lab.tracking.track import TrackResult, TrackResultError

    n = 2
    res = TrackResult(
        "t",
        np.zeros((n, 3)),
        np.zeros((n, 3)),
        np.array([[0.1, 0, 0], [np.nan] * 3]),
        np.zeros((n, 3)),
        np.zeros(n),
        np.ones(n, bool),
        np.ones(n, int),
        np.ones(n, bool),
        np.zeros(n),
        {"ik_total_s": 0.0},
    )
    write_result(tmp_path / "r.json", res)
    doc = read_result(tmp_path / "r.json")
    assert np.isnan(doc["achieved"][1]).all() and np.isnan(doc["errors_m"][1])
    (tmp_path / "bad.json").write_text('{"targets": []}')
    with pytest.raises(TrackResultError, match="missing"):
        read_result(tmp_path / "bad.json")


def test_table1_rows_merge(tmp_path):
    csv, md = tmp_path / "table1.csv", tmp_path / "table1.md"
    table1.update_table1(
        {
            "Sim Data + Sim Robot": {"circle": 0.003, "square": 0.004, "rose": 0.002},
            "Soft IK + Sim Robot": {"circle": 0.0, "square": 0.0, "rose": 0.0},
        },
        csv,
        md,
        source="notebook 04",
    )
    table1.update_table1({"Real Data + Real Robot": {"circle": 0.2, "rose": 0.3}}, csv, md, source="rig")
    rows = table1.read_table1(csv)
    assert list(rows) == ["Real Data + Real Robot", "Sim Data + Sim Robot", "Soft IK + Sim Robot"]
    assert float(rows["Sim Data + Sim Robot"]["circle_cm"]) == 0.003  # kept
    assert rows["Real Data + Real Robot"]["square_cm"] == ""  # not measured
    assert float(rows["Real Data + Real Robot"]["paper_rose_cm"]) == 0.22
    assert rows["Soft IK + Sim Robot"]["paper_circle_cm"] == ""
    table1.update_table1({"Sim Data + Sim Robot": {"circle": 0.005}}, csv, md, source="rerun")
    rows = table1.read_table1(csv)
    assert float(rows["Sim Data + Sim Robot"]["circle_cm"]) == 0.005 and len(rows) == 3
    text = md.read_text()
    assert "| Sim Data + Sim Robot | 0.005 | 0.050 |" in text and "Real Data + Real Robot" in text
    with pytest.raises(table1.Table1Error, match="unknown trajectories"):
        table1.update_table1({"Sim Data + Sim Robot": {"star": 1.0}}, csv, md, source="x")
    with pytest.raises(table1.Table1Error, match="finite"):
        table1.update_table1({"Sim Data + Sim Robot": {"circle": float("nan")}}, csv, md, source="x")


def test_a_rerun_never_loses_the_kept_points(model_file, tmp_path, monkeypatch, capsys):
    """An ILC run stopped after 6 points, a rerun stopped after 2, a rerun whose rig fails at
    once: the points file only grows (6, then 8 rows, then the same bytes); a run that
    completes writes the result and removes it."""
    from lab.capture.protocol import measure as real_measure

    out, points = tmp_path / "r.json", tmp_path / "r.json.points.csv"
    argv = ["track", "--model", str(model_file), "--trajectory", "circle", "--n-points", "4", *COARSE]
    argv += ["--closed-loop", "ilc", "--passes", "3", "--out", str(out)]

    def stop_after(n):
        calls = []

        def measure(rig, u, protocol):
            calls.append(1)
            if len(calls) > n:
                raise KeyboardInterrupt
            return real_measure(rig, u, protocol)

        return measure

    monkeypatch.setattr("lab.tracking.closed_loop.measure", stop_after(6))
    assert main(argv) == 130
    assert len(points.read_text().splitlines()) == 1 + 6 and "the 6 points measured so far" in capsys.readouterr().err
    monkeypatch.setattr("lab.tracking.closed_loop.measure", stop_after(2))
    assert main(argv) == 130
    err = capsys.readouterr().err
    assert "the 2 points measured so far" in err and "after 6 kept from an earlier run" in err
    lines = points.read_text().splitlines()
    assert (
        len(lines) == 1 + 8 and lines[0].startswith("i,target_x") and [r.split(",")[0] for r in lines[7:]] == ["0", "1"]
    )
    kept = points.read_bytes()

    def no_rig(*args, **kwargs):
        raise RigError("servo bus: no such device")

    monkeypatch.setattr("lab.jobs.track.make_rig", no_rig)
    assert main(argv) == 1
    assert points.read_bytes() == kept and "the 8 points kept from an earlier run" in capsys.readouterr().err
    monkeypatch.undo()
    assert main(argv) == 0 and len(json.loads(out.read_text())["passes"]) == 3 and not points.exists()
