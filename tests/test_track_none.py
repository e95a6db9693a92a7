"""``track --rig none``: the IK's commands for a lab's own robot, from a model of measured data.

The models are trained here, with ``python -m lab train``, on a synthetic 6-motor
"measured" dataset (negative commands, like the ASL Trunk's efforts; sidecar robot kind
"measured"; two measurement sequences), so the commands must stay in the box of the
training data, which no robot description gives. Rows for bad input are in
tests/sweep_rig_none.py.
"""

import json
from pathlib import Path

import numpy as np
import pytest
from helpers import fd_jacobian

from lab.cli import main
from lab.control import CommandSet, IKSolver, command_set, predicted_spread_m
from lab.control.trajectories import write_trajectory_csv
from lab.data import write_dataset
from lab.description import load_robot
from lab.errors import InputError
from lab.learn.history import at_rest, data_bounds, history_of, with_past
from lab.learn.models import load_model
from lab.rig import RigSpec, make_rig

DATA = Path(__file__).resolve().parent.parent / "data"
M = 6
U_LO, U_HI = -3.0, -0.5


def _tip(u):
    """A smooth synthetic tip map (m) of six negative efforts."""
    A = np.random.default_rng(7).normal(0, 0.02, (3, M))
    return 0.1 * np.tanh(3 * u @ A.T) + np.array([0.2, 0.0, 0.0])


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    """The dataset and three models trained on it: mlp, a 2-member ensemble, history K = 2."""
    d = tmp_path_factory.mktemp("measured")
    u = np.random.default_rng(0).uniform(U_LO, U_HI, (400, M))
    robot = {"name": "trunk", "kind": "measured", "n_motors": M, "u_min": [U_LO] * M, "u_max": [U_HI] * M,
             "u_unit": "N", "y_unit": "m"}  # fmt: skip
    write_dataset(d / "d.csv", u, _tip(u), {"robot": robot, "sequence_starts": [0, 200]})
    common = ["train", str(d / "d.csv"), "--hidden", "8", "--epochs", "60"]
    for name, extra in (("mlp", []), ("ens", ["--model", "ensemble", "--members", "2"]), ("hist", ["--history", "2"])):
        assert main([*common, *extra, "--out", str(d / f"{name}.npz")]) == 0
    return d


def _track(d, model, targets, out="r.json", extra=()):
    write_trajectory_csv(d / "targets.csv", targets)
    argv = ["track", "--rig", "none", "--model", str(d / model), "--trajectory", str(d / "targets.csv")]
    assert main([*argv, *extra, "--out", str(d / out)]) == 0
    doc = json.loads((d / out).read_text())
    lines = (d / f"{out}.commands.csv").read_text().splitlines()
    return doc, lines[0].split(","), np.loadtxt(lines[1:], delimiter=",", ndmin=2)


def _targets(model, n, seed):
    """n targets the model reaches (its tip at random commands inside the data box) and one far away."""
    u = np.random.default_rng(seed).uniform(U_LO + 0.3, U_HI - 0.3, (n, M))
    return np.vstack([at_rest(model).predict(u), [[0.5, 0.3, -0.3]]])


def test_commands_for_a_measured_robot(measured, capsys):
    model = load_model(measured / "mlp.npz")
    lo, hi = data_bounds(model)
    targets = _targets(model, 6, 1)
    doc, header, rows = _track(measured, "mlp.npz", targets)
    u, pred = np.array(doc["commands"]), np.array(doc["predicted"])
    assert header == [f"u{j}" for j in range(M)] + ["x_pred", "y_pred", "z_pred", "error_m"]
    assert doc["kind"] == "lab.track.commands" and doc["rig"] == "none" and doc["history"] == 0
    np.testing.assert_array_equal(doc["command_bounds"]["u_min"], lo)
    # every command inside the data box -- also for the far target, which pushes to its edge
    assert np.all(u >= lo - 1e-12) and np.all(u <= hi + 1e-12) and np.all(u < 0)
    assert np.isclose(u[-1], lo).any() or np.isclose(u[-1], hi).any()
    np.testing.assert_allclose(pred, model.predict(u), rtol=0, atol=1e-14)
    err = np.linalg.norm(pred - targets, axis=1)
    np.testing.assert_allclose(doc["predicted_error_m"], err, rtol=1e-12, atol=1e-15)
    assert err[:-1].max() < 1e-5 and doc["reachable"] == [True] * 6 + [False] and err[-1] > 0.1
    np.testing.assert_allclose(rows, np.column_stack([u, pred, err]), rtol=1e-15, atol=0)
    assert doc["predicted_spread_m"] == [None] * 7 and doc["uncertain"] == [False] * 7
    assert not (measured / "r.json.points.csv").exists()
    assert "7 targets solved through the model, no rig" in capsys.readouterr().err


def test_an_ensembles_spread_is_written(measured):
    model = load_model(measured / "ens.npz")
    doc, header, rows = _track(measured, "ens.npz", _targets(model, 3, 2), out="e.json")
    u = np.array(doc["commands"])
    assert header[-2:] == ["error_m", "spread_m"]
    spread = [predicted_spread_m(model, ui) for ui in u]
    np.testing.assert_allclose(rows[:, -1], spread, rtol=1e-12)
    np.testing.assert_allclose(doc["predicted_spread_m"], spread, rtol=1e-12)
    assert doc["uncertain"] == [s > 1e-3 for s in spread] and doc["info"]["solver"]["max_spread_m"] == 1e-3


def test_a_history_model_takes_the_answers_before_as_its_past(measured):
    model = load_model(measured / "hist.npz")
    assert history_of(model) == 2
    doc, header, rows = _track(measured, "hist.npz", _targets(model, 4, 3)[:-1], out="h.json")
    u, pred = np.array(doc["commands"]), np.array(doc["predicted"])
    assert doc["history"] == 2 and len(header) == M + 4
    past = [u[0], u[0]]  # the robot resting at the first answer
    for i, ui in enumerate(u):
        np.testing.assert_allclose(pred[i], model.predict(np.concatenate([ui, *past])), rtol=0, atol=1e-14)
        past = [ui, past[0]]
    assert max(doc["predicted_error_m"]) < 1e-5 and all(doc["reachable"])


def test_the_restricted_models_jacobian(measured):
    import torch

    model = load_model(measured / "hist.npz")
    u = np.random.default_rng(4).uniform(U_LO, U_HI, (5, M))
    past = np.random.default_rng(5).uniform(U_LO, U_HI, (2, M))
    t = lambda a: torch.tensor(a, dtype=torch.float64)  # noqa: E731

    def f_torch(x):  # the network in torch, from its weights
        a = (x - t(model.u_min)) * t(model.u_gain) - 1.0
        for W, b in zip(model.weights[:-1], model.biases[:-1]):
            a = torch.tanh(a @ t(W).T + t(b))
        return (a @ t(model.weights[-1]).T + t(model.biases[-1]) + 1.0) / t(model.y_gain) + t(model.y_min)

    for restricted, inputs in (
        (with_past(model, past), lambda v: torch.cat([v, t(past.ravel())])),
        (at_rest(model), lambda v: torch.cat([v, v, v])),
    ):
        J = restricted.jacobian(u)
        assert J.shape == (5, 3, M)
        assert np.abs(J - fd_jacobian(restricted.predict, u)).max() <= 1e-6 * np.abs(J).max()
        f = lambda v, x=inputs: f_torch(x(v))  # noqa: E731
        J_t = np.array([torch.autograd.functional.jacobian(f, t(ui)).numpy() for ui in u])
        np.testing.assert_allclose(J, J_t, rtol=1e-10, atol=1e-12 * np.abs(J_t).max())


def test_for_model_without_a_robot():
    from lab.learn.mlp import MLP

    rng = np.random.default_rng(0)
    net = lambda n_y: MLP([rng.normal(size=(4, 3)), rng.normal(size=(n_y, 4))], [np.zeros(4), np.zeros(n_y)],  # noqa: E731
                          -np.ones(3), np.ones(3), np.zeros(n_y), np.ones(n_y))  # fmt: skip
    box = (np.array([-2.0, -1.0, 0.5]), np.array([-1.0, 1.0, 2.0]))
    solver = IKSolver.for_model(net(3), None, bounds=box)
    np.testing.assert_array_equal(solver.commands.lo, box[0])
    np.testing.assert_array_equal(solver.commands.hi, box[1])
    seeds = solver.seeds[0]
    assert seeds.shape == (7**3, 3) and np.all(seeds >= box[0]) and np.all(seeds <= box[1])
    with pytest.raises(InputError, match="predicts 2 outputs, but the targets have 3 columns"):
        IKSolver.for_model(net(2), None, bounds=box)
    with pytest.raises(InputError, match="needs a model and the bounds of its training data"):
        IKSolver.for_model(net(3), None)
    with pytest.raises(InputError, match="motor 1 has no range"):
        IKSolver.for_model(net(3), None, bounds=(box[0], np.array([-1.0, -1.0, 2.0])))
    with pytest.raises(InputError, match="maps 3 inputs to 3 outputs, but the command bounds are for 2 motors"):
        IKSolver.for_model(net(3), None, bounds=(box[0][:2], box[1][:2]))
    # with a robot too: its allowed set cut to the box (the six-cable arm keeps its safety rows)
    six = load_robot("six-cable")
    full, cut = CommandSet.from_robot(six), command_set(six, (np.full(6, 0.5), np.full(6, 5.0)))
    np.testing.assert_array_equal(cut.lo, np.full(6, 0.5))
    np.testing.assert_array_equal(cut.hi, full.hi)
    np.testing.assert_array_equal(cut.A, full.A)
    assert len(cut.b) == len(six.safety_limits) > 0


def test_rig_none_is_for_track_only():
    spec = RigSpec.parse("none", allow_none=True)
    assert spec.kind == "none" and not spec.has_rig and str(spec) == "none" and not spec.has_dynamics
    with pytest.raises(InputError, match="taken by `track` only"):
        RigSpec.parse("none")
    with pytest.raises(InputError, match="RigSpec.rig none is no rig"):
        make_rig(spec, load_robot("three-cable"))
    with pytest.raises(InputError, match="RigSpec.rig none is no rig"):
        spec.require_dynamics()
    from lab.jobs.track import TrackSpec

    with pytest.raises(InputError, match=r"^TrackSpec.seed is not used with RigSpec.rig none \(it seeds"):
        TrackSpec(trajectory="p.csv", model="m.npz", rig=spec, robot="six-cable", seed=1)
    with pytest.raises(InputError, match=r"^TrackSpec.soft_ik is not used with RigSpec.rig none \(Soft IK solves"):
        TrackSpec(trajectory="p.csv", rig=spec)


def test_the_report_names_the_ik_residual_and_the_uncertainty(measured, capsys):
    """Nothing is measured: the summary says "IK residual through the model", never "error",
    and says what the model knows of its uncertainty (an ensemble's spread, or none)."""
    model = load_model(measured / "mlp.npz")
    doc, _, _ = _track(measured, "mlp.npz", _targets(model, 3, 5), out="n.json")
    lines = capsys.readouterr().err.splitlines()[-3:]
    residual = np.linalg.norm(np.array(doc["predicted"]) - np.array(doc["targets"]), axis=1)
    np.testing.assert_allclose(doc["ik_residual_m"], residual, rtol=1e-12, atol=1e-15)
    assert doc["predicted_error_m"] == doc["ik_residual_m"]  # the earlier key, kept for files already read
    assert doc["max_ik_residual_m"] == max(doc["ik_residual_m"]) and doc["units"]["residuals"] == "m"
    assert doc["uncertainty"] == {"source": None, "mean_spread_m": None, "max_spread_m": None}
    assert any("IK residual through the model" in line for line in lines)
    assert any("no uncertainty estimate" in line for line in lines)
    assert not any("error" in line for line in lines), lines

    ens = load_model(measured / "ens.npz")
    doc, _, _ = _track(measured, "ens.npz", _targets(ens, 3, 6), out="u.json")
    lines = capsys.readouterr().err.splitlines()[-3:]
    spread = [predicted_spread_m(ens, ui) for ui in np.array(doc["commands"])]
    u = doc["uncertainty"]
    assert u["source"] == "ensemble spread (2 members)"
    assert np.isclose(u["mean_spread_m"], np.mean(spread), rtol=1e-12) and np.isclose(u["max_spread_m"], max(spread))
    assert any(
        f"uncertainty: ensemble spread (2 members) mean {1e3 * np.mean(spread):.3g} mm" in line for line in lines
    )
    assert not any("error" in line for line in lines), lines


def test_a_redundant_arms_commands_do_not_jump_between_neighbouring_targets(tmp_path):
    """The shipped six-cable model (six motors for three tip coordinates) on its rings: a
    plain warm start drifts along the answers to a motor bound, misses, restarts from the
    posture and jumps across the box (measured: 2.46 rad, 82 % of the 3 rad box, on
    six-ring; 1.94 rad, 65 %, on six-spiral; the neighbouring steps are 0.06 rad). The
    smooth path keeps every step within 0.061 rad (2.0 %) and 0.132 rad (4.4 %); the bound
    is 10 % of the box, twice the larger."""
    for name in ("six-ring", "six-spiral"):
        out = tmp_path / f"{name}.json"
        argv = ["track", "--rig", "none", "--model", str(DATA / "model_sim_six_cable.npz"), "--trajectory", name]
        assert main([*argv, "--out", str(out)]) == 0
        doc = json.loads(out.read_text())
        u, lo, hi = (np.array(v) for v in (doc["commands"], *doc["command_bounds"].values()))
        fraction = np.abs(np.diff(u, axis=0)) / (hi - lo)
        assert fraction.max() <= 0.1, (name, fraction.max())
        assert all(doc["reachable"]) and doc["info"]["solver"]["smooth_path"] is True
        steps = doc["command_steps"]
        assert np.isclose(steps["max_fraction_of_box"], fraction.max(), rtol=1e-12)
        assert steps["max"] == np.abs(np.diff(u, axis=0)).max() and steps["at"] == 1 + fraction.max(1).argmax()


def test_a_file_by_the_commands_files_name_is_never_overwritten(tmp_path, capsys):
    """OUT.commands.csv is the --out name with .commands.csv appended, as the help says; a
    file of that name this program did not write is refused (exit 2, nothing changed), an
    earlier run's is replaced."""
    with pytest.raises(SystemExit):
        main(["track", "--help"])
    assert "--out plan.json writes plan.json.commands.csv" in " ".join(capsys.readouterr().out.split())
    argv = ["track", "--rig", "none", "--model", str(DATA / "model_sim_three_cable.npz"), "--trajectory", "circle"]
    argv += ["--n-points", "5", "--out", str(tmp_path / "plan.json")]
    mine = tmp_path / "plan.json.commands.csv"
    mine.write_text("my own notes\n")
    assert main(argv) == 2
    assert "is not one this program wrote" in capsys.readouterr().err
    assert mine.read_text() == "my own notes\n" and not (tmp_path / "plan.json").exists()
    mine.unlink()
    assert main(argv) == 0 and main(argv) == 0  # the second run replaces the first's file
    assert len(mine.read_text().splitlines()) == 6 and not (tmp_path / "plan.commands.csv").exists()


def test_a_targets_file_with_a_byte_order_mark_and_crlf_lines(tmp_path):
    from lab.control.trajectories import read_trajectory_csv

    (tmp_path / "t.csv").write_bytes(b"\xef\xbb\xbfx,y,z\r\n0.18,0.01,0\r\n0.18,0,0.01\r\n")
    np.testing.assert_array_equal(read_trajectory_csv(tmp_path / "t.csv"), [[0.18, 0.01, 0], [0.18, 0, 0.01]])


def test_command_steps_name_the_jumps():
    from lab.tracking.solved_targets import JUMP_FRACTION, command_steps

    u = np.array([[0.0, 1.0], [0.1, 1.0], [2.9, 1.0], [2.9, 1.2]])
    steps = command_steps(u, np.zeros(2), np.array([3.0, 2.0]))
    assert steps == {"max": 2.8, "max_fraction_of_box": 2.8 / 3.0, "at": 2, "jumps": [2]} and JUMP_FRACTION == 0.25
    assert command_steps(u[:1], np.zeros(2), np.ones(2))["jumps"] == []
