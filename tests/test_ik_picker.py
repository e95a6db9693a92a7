"""Chapter 04's IK target picker (:class:`lab.viz.IKPicker`), its callbacks called headless,
and the projected gradient step of exercise 4.1 (:func:`lab.control.projected_gradient_step`)."""

from pathlib import Path

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

from lab.control import CommandSet, IKConfig, IKSolver, projected_gradient_step, trajectories  # noqa: E402
from lab.errors import InputError  # noqa: E402
from lab.learn import load_model  # noqa: E402
from lab.viz import IKPicker  # noqa: E402
from lab.viz import ik_picker as picker_module  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
OUT_OF_REACH_W = np.array([0.25, 0.10, 0.05])  # m: 25 cm out along a 20 cm arm


@pytest.fixture(scope="module")
def model():
    return load_model(ROOT / "data" / "model_sim_three_cable.npz")


@pytest.fixture(scope="module")
def picker(model, three_cable, coarse_fem):
    return IKPicker(model, three_cable, coarse_fem, targets_W=trajectories.builtin("square", 12))


def test_picker_moves_the_arm_to_a_reachable_target(picker, model):
    import matplotlib.pyplot as plt

    u_star = np.array([1.4, 0.6, 0.9])
    target = model.predict(u_star)
    out = picker.update(target)
    assert out["reachable"] and out["status"] == "converged"
    assert np.linalg.norm(out["p_pred_W"] - target) < 1e-5  # the model's tip is on the target
    assert picker.solver.commands.contains(out["u_motor"])
    # the FEM arm drawn at that command: the coarse test mesh is not the trained one, so
    # its tip sits within the model error plus the mesh's coarseness (millimetres)
    assert out["q"] is not None and np.linalg.norm(out["p_tip_W"] - target) < 0.01
    # the tip path runs from the previous tip to the new one, through the model
    np.testing.assert_allclose(out["path_W"][-1], model.predict(out["u_motor"]), atol=1e-12)
    assert "reached" in picker.fig._suptitle.get_text()
    bars = [p.get_height() for p in picker.axes[2].patches]
    np.testing.assert_allclose(bars, out["u_motor"])
    plt.close(picker.fig)
    picker.fig = None


def test_picker_answers_fast_through_the_learned_model(model, three_cable):
    light = IKPicker(model, three_cable)  # no FEM: the arm is sketched
    light.update(trajectories.CENTRE_W, draw=False)
    for target in trajectories.builtin("square", 8):
        out = light.update(target, draw=False)
        assert out["reachable"] and out["q"] is None and out["p_tip_W"] is None
        assert out["ik_s"] < 0.2, f"IK took {out['ik_s']:.3f} s"
    arc = picker_module.arc_W(out["p_pred_W"])
    np.testing.assert_allclose(arc[0], 0.0, atol=1e-15)  # leaves the base ...
    np.testing.assert_allclose(arc[-1], out["p_pred_W"], atol=1e-12)  # ... and ends at the tip
    assert np.all(np.abs(np.diff(arc[:2], axis=0)[0, 1:]) < 0.1 * np.diff(arc[:2], axis=0)[0, 0])  # along +x


def test_picker_handles_out_of_reach_and_invalid_targets(picker):
    import matplotlib.pyplot as plt

    out = picker.update(OUT_OF_REACH_W)
    assert not out["reachable"] and out["residual_m"] > 0.01
    assert np.all(np.isfinite(out["u_motor"])) and picker.solver.commands.contains(out["u_motor"])
    assert "out of reach" in picker.fig._suptitle.get_text()
    plt.close(picker.fig)
    picker.fig = None
    with pytest.raises(InputError, match="not finite"):
        picker.update([0.18, np.nan, 0.0])
    with pytest.raises(InputError):
        picker.update([0.18, 0.0])
    assert picker.last["p_target_W"] is not None and np.all(np.isfinite(picker.u_motor))


def test_no_front_end_gives_the_static_result(picker, capsys, monkeypatch):
    import matplotlib.pyplot as plt

    assert not picker_module.front_end_available()  # plain Python: no kernel
    monkeypatch.setattr(picker_module, "front_end_available", lambda: False)
    assert picker.widget(p_start_W=trajectories.CENTRE_W) is None
    assert "no widget front end" in capsys.readouterr().out
    np.testing.assert_allclose(picker.last["p_target_W"], trajectories.CENTRE_W)
    assert picker.fig is not None
    plt.close(picker.fig)
    picker.fig = None


def test_sliders_and_trajectory_points_drive_the_callback(picker, monkeypatch):
    pytest.importorskip("ipywidgets")
    monkeypatch.setattr(picker_module, "front_end_available", lambda: True)
    box = picker.widget()
    x, y, z, points, status = box.children[:5]
    assert [s.description for s in (x, y, z)] == ["target x [cm]", "target y [cm]", "target z [cm]"]
    np.testing.assert_allclose(picker.last["p_target_W"], picker.targets_W[0], atol=1e-9)  # the start
    y.value = y.value - 0.5  # what dragging the y slider does
    assert picker.last["p_target_W"][1] == pytest.approx(picker.targets_W[0][1] - 0.005)
    assert "ms" in status.value
    points.value = 5  # a trajectory point: one solve, at that point
    np.testing.assert_allclose(picker.last["p_target_W"], picker.targets_W[5], atol=1e-9)
    assert picker.last["reachable"]
    picker.fig = None


def test_projected_gradient_step_is_the_solvers_trial_step(model, three_cable):
    commands = CommandSet.from_robot(three_cable)
    rng = np.random.default_rng(3)
    for _ in range(4):
        u0 = commands.project(rng.uniform(0, 3, 3))
        target = model.predict(commands.project(rng.uniform(0, 3, 3)))
        _, J = model.predict_and_jacobian(u0)
        first = IKSolver(model, commands, IKConfig("gd", max_iter=1)).solve(target, u0)
        assert first.evaluations == 2  # Armijo took the first trial step, 1 / |J|_F^2
        step = projected_gradient_step(model, u0, target, 1.0 / np.sum(J * J), commands)
        np.testing.assert_array_equal(step, first.u_motor)


def test_projected_gradient_step_clips_to_a_box_and_projects_onto_the_safety_plane(model, three_cable):
    u = np.array([2.9, 2.8, 0.2])
    target = model.predict(np.array([0.0, 0.0, 3.0]))  # far: a long step leaves the box
    y, J = model.predict_and_jacobian(u)
    free = u - 1e4 * J.T @ (y - target)
    box = CommandSet(np.zeros(3), np.full(3, 3.0))
    clipped = projected_gradient_step(model, u, target, 1e4, box)
    np.testing.assert_allclose(clipped, np.clip(free, 0.0, 3.0))  # the paper's clip
    safe = CommandSet.from_robot(three_cable)
    projected = projected_gradient_step(model, u, target, 1e4, safe)
    assert safe.contains(projected)
    np.testing.assert_allclose(projected, safe.project(free))
    with pytest.raises(InputError):
        projected_gradient_step(model, u, target, -1.0, box)
