"""Closed-loop tracking (issue 16): ILC and per-target feedback through the model's Jacobian."""

import json

import numpy as np
import pytest

from lab.cli import main
from lab.control.command_set import CommandSet
from lab.control.ik import IKSolver
from lab.control.trajectories import write_trajectory_csv
from lab.rig.base import MocapFrame, Rig
from lab.tracking import closed_loop as cl
from lab.tracking.closed_loop import Correction, correct_command, run_closed_loop, tip_from_frames
from lab.tracking.track import REQUIRED_KEYS, TrackResultError, read_result

C = np.array([0.2, 0.0, -0.01])
B = 0.01 * np.array([[-0.1, -0.1, -0.1], [0.0, -1.0, 1.0], [1.0, -0.5, -0.5]])  # m/rad, full rank


class LinearRig(Rig):
    """A plant whose tip is ``c + B u`` at once (motors instant), 120 Hz frames; every
    ``nan_every``-th frame occluded; for the commands sent ``dark`` (indices of ``send``, one
    per measurement) every frame read by ``wait()`` -- the closed loop's averaging window,
    after the settle rule -- occluded, for ``dark_for_s`` from its start."""

    kind = "linear"

    def __init__(self, robot, c=C, B=B, noise_m=0.0, nan_every=0, dark=(), dark_for_s=np.inf):
        super().__init__(robot, 120.0)
        self.c, self.B, self.noise_m, self.nan_every, self.dark = c, B, noise_m, nan_every, set(dark)
        self.t, self.u, self.n, self._dark_now = 0.0, np.zeros(3), 0, False
        self.dark_for_s, self._dark_until = dark_for_s, {}  # measurement -> end of its darkness
        self.rng = np.random.default_rng(0)
        self.sent = []

    def _send(self, u):
        self.u = u.copy()
        self.sent.append(u.copy())

    def present_u(self):
        return self.u.copy()

    def now(self):
        return self.t

    def next_frame(self):
        self.t += 1 / 120
        self.n += 1
        if (self._dark_now and self.t < self._dark_until[len(self.sent) - 1]) or (
            self.nan_every and self.n % self.nan_every == 0
        ):
            return MocapFrame(self.t, np.full(3, np.nan))
        return MocapFrame(self.t, self.c + self.B @ self.u + self.noise_m * self.rng.standard_normal(3))

    def wait(self, duration_s):
        self._dark_now = len(self.sent) - 1 in self.dark
        self._dark_until.setdefault(len(self.sent) - 1, self.t + self.dark_for_s)
        try:
            return super().wait(duration_s)
        finally:
            self._dark_now = False


class Linear:
    """Model p = c + B u, whose Jacobian B may differ from the plant's."""

    def __init__(self, c, B):
        self.c, self.B = np.asarray(c, float), np.asarray(B, float)
        self.n_jacobians = 0

    def predict_and_jacobian(self, u):
        self.n_jacobians += 1
        return self.c + self.B @ u, self.B.copy()


WRONG = np.eye(3) + np.array([[0.15, -0.1, 0.05], [0.1, 0.2, -0.1], [-0.05, 0.1, -0.15]])  # a 15-20 % error
U_IN = np.array([[1.0, 0.5, 0.5], [1.2, 0.4, 0.9], [0.5, 1.5, 0.3], [2.0, 2.0, 1.0]])  # allowed commands


def _rho(B_true, B_model, gain, damping):
    """Contraction factor of the unconstrained ILC error map e <- (I - gain B (B_m+) ) e, with
    the damped pseudo-inverse computed as the least-squares solution of the stacked system."""
    lam = damping * np.linalg.svd(B_model, compute_uv=False)[0]
    stacked = np.vstack([B_model, lam * np.eye(3)])
    pinv = np.linalg.lstsq(stacked, np.vstack([np.eye(3), np.zeros((3, 3))]), rcond=None)[0]
    return np.linalg.norm(np.eye(3) - gain * B_true @ pinv, 2)


def test_ilc_converges_geometrically_on_a_linear_plant(three_cable):
    """A model with the wrong offset and a Jacobian ~20 % off: open loop misses by mm, each ILC
    pass shrinks every target's error at least by the contraction factor of the error map."""
    model = Linear(C + [0.001, -0.002, 0.0015], WRONG @ B)
    targets = C + U_IN @ B.T
    solver = IKSolver(model, CommandSet.from_robot(three_cable))
    corr = Correction(gain=0.9, max_step_rad=2.0)  # the step limit off: the linear error map
    with LinearRig(three_cable) as rig:
        res = run_closed_loop(rig, solver, targets, passes=6, correction=corr)
    rho = _rho(B, WRONG @ B, 0.9, corr.damping)
    assert 0.05 < rho < 0.5
    err = np.array([np.linalg.norm(np.array(p["achieved"]) - targets, axis=1) for p in res.passes])
    assert err[0].min() > 1e-3  # open loop: the model's offset
    for k in range(5):
        assert np.all(err[k + 1] <= rho * err[k] + 1e-12)
    assert res.mean_error_m < 1e-3 * rho**5 * 10 and res.mean_error_m == pytest.approx(err[-1].mean())
    assert [p["pass"] for p in res.passes] == list(range(6)) and all(p["n_skipped"] == 0 for p in res.passes)
    np.testing.assert_allclose(res.commands, res.passes[-1]["commands"])


def test_ilc_stays_allowed_with_targets_out_of_reach(three_cable):
    """Targets beyond u_max and beyond the safety rule: every command ever sent is allowed, and
    with an exact model the ILC ends at the constrained least-squares optimum (what the QP
    step converges to; a clipped pseudo-inverse step would stop elsewhere)."""
    commands = CommandSet.from_robot(three_cable)
    u_star = np.array([[3.6, 0.2, 0.2], [2.9, 2.9, 2.9], [1.0, 0.5, 0.5]])  # box, safety rule, inside
    targets = C + u_star @ B.T
    best = [commands.solve_qp(B.T @ B, -B.T @ (t - C)) for t in targets]
    best_err = np.linalg.norm(C + np.array(best) @ B.T - targets, axis=1)
    assert best_err[0] > 1e-3 and best_err[1] > 1e-3 and best_err[2] < 1e-12
    for model, passes in ((Linear(C + 0.001, B), 8), (Linear(C, WRONG @ B), 8)):
        solver = IKSolver(model, commands)
        with LinearRig(three_cable) as rig:
            res = run_closed_loop(rig, solver, targets, passes=passes, correction=Correction(max_step_rad=0.5))
        sent = np.array(rig.sent)
        assert all(commands.contains(u, 1e-9) for u in sent) and np.all(three_cable.is_safe(sent))
        for p in res.passes:
            assert all(commands.contains(u, 1e-9) for u in p["commands"])
        steps = np.diff([p["commands"] for p in res.passes], axis=0)
        assert np.abs(steps).max() <= 0.5 + 1e-12  # the step limit per correction
        if model.B is B:  # exact Jacobian: the constrained optimum
            np.testing.assert_allclose(res.errors_m, best_err, atol=1e-6)
        else:  # wrong Jacobian: still in C, no worse than open loop, reachable target met
            open_loop = np.linalg.norm(np.array(res.passes[0]["achieved"]) - targets, axis=1)
            assert np.all(res.errors_m <= open_loop + 1e-9)
            assert res.errors_m[2] < 1e-6


def test_tip_from_frames_leaves_nan_frames_out():
    rng = np.random.default_rng(1)
    pts = rng.normal(size=(12, 3))
    pts[[1, 4, 5, 9]] = np.nan
    pts[7, 2] = np.nan  # one coordinate missing: the whole frame is invalid
    p, n = tip_from_frames(pts, 6)
    keep = [0, 2, 3, 6, 8, 10, 11]
    assert n == 7 and np.allclose(p, pts[keep].mean(axis=0))
    p, n = tip_from_frames(pts, 8)  # too few valid frames: no measurement
    assert n == 7 and np.all(np.isnan(p))
    assert np.all(np.isnan(tip_from_frames(np.full((5, 3), np.nan), 1)[0]))


def test_a_nan_measurement_never_reaches_the_update(three_cable):
    model = Linear(C, B)
    commands = CommandSet.from_robot(three_cable)
    u = np.array([1.0, 0.5, 0.5])
    for bad in ([np.nan, 0.2, 0.0], [np.inf, 0.0, 0.0], [np.nan] * 3):
        assert np.array_equal(correct_command(commands, model, u, C, bad), u)
    assert model.n_jacobians == 0  # the Jacobian was never even asked for


def test_nan_frames_are_filtered_and_dark_windows_skip_the_correction(three_cable, monkeypatch):
    """Every third frame occluded: each correction sees exactly the noise-free tip (the mean of
    the valid frames). Two averaging windows wholly occluded (target 1 in pass 0, target 2 in
    pass 1): those targets keep their command for the next pass, and the skips are counted."""
    seen = []
    real = cl.correct_command

    def spy(commands, forward, u, target, measured, *rest):
        seen.append((np.array(u), np.array(measured)))
        return real(commands, forward, u, target, measured, *rest)

    monkeypatch.setattr(cl, "correct_command", spy)
    model = Linear(C + 0.001, WRONG @ B)
    targets = C + U_IN[:3] @ B.T
    solver = IKSolver(model, CommandSet.from_robot(three_cable))
    with LinearRig(three_cable, nan_every=3, dark={1, 5}) as rig:  # measurement of pass k target i: 3k + i
        res = run_closed_loop(rig, solver, targets, passes=3)
    valid = [(u, m) for u, m in seen if np.all(np.isfinite(m))]
    assert len(seen) == 6 and len(valid) == 4
    for u, m in valid:
        np.testing.assert_allclose(m, C + B @ u, atol=1e-12)  # NaN frames left out, nothing else
    P = [np.array(p["commands"]) for p in res.passes]
    np.testing.assert_array_equal(P[1][1], P[0][1])  # skipped after pass 0
    np.testing.assert_array_equal(P[2][2], P[1][2])  # skipped after pass 1
    assert not np.array_equal(P[1][0], P[0][0])
    assert [p["n_skipped"] for p in res.passes] == [1, 1, 0] and res.info["closed_loop"]["n_skipped"] == 2
    assert np.all(np.isfinite(res.achieved_W))  # a dark window still reports the protocol's reading


def test_feedback_mode_corrects_each_target_before_moving_on(three_cable):
    model = Linear(C + [0.001, -0.002, 0.0015], WRONG @ B)
    targets = C + U_IN @ B.T
    solver = IKSolver(model, CommandSet.from_robot(three_cable))
    with LinearRig(three_cable, noise_m=2e-5) as rig:
        res = run_closed_loop(rig, solver, targets, mode="feedback", passes=4)
        sent = np.array(rig.sent)
    # target by target: four measurements near target 0, then four near target 1, ...
    tips = C + sent @ B.T
    nearest = np.argmin(np.linalg.norm(tips[:, None] - targets[None], axis=2), axis=1)
    assert nearest.tolist() == np.repeat(np.arange(4), 4).tolist()
    means = [p["mean_error_m"] for p in res.passes]
    assert means[0] > 2e-3 and means[3] < 1e-4 and means == sorted(means, reverse=True)


def test_bad_settings_are_input_errors(three_cable):
    from lab.errors import InputError

    for kw in ({"gain": 0.0}, {"gain": 2.0}, {"damping": 0.0}, {"window_s": -1}, {"min_valid_fraction": 0}):
        with pytest.raises(InputError):
            Correction(**kw)
    solver = IKSolver(Linear(C, B), CommandSet.from_robot(three_cable))
    with LinearRig(three_cable) as rig:
        with pytest.raises(InputError, match="passes"):
            run_closed_loop(rig, solver, C[None], passes=0)
        with pytest.raises(InputError, match="mode"):
            run_closed_loop(rig, solver, C[None], mode="pid")


def test_track_cli_closed_loop_writes_passes(tmp_path, capsys):
    """The shipped sim model on the emulated as-built robot (~6 mm open-loop error): ILC with
    three passes writes the open-loop keys plus ``passes``, and the error falls pass by pass."""
    base = ["track", "--model", "data/model_sim_three_cable.npz", "--rig", "twin", "--trajectory", "circle"]
    base += ["--n-points", "4"]
    assert main([*base, "--out", str(tmp_path / "open.json")]) == 0
    assert main([*base, "--closed-loop", "ilc", "--passes", "3", "--out", str(tmp_path / "ilc.json")]) == 0
    err = capsys.readouterr().err
    assert "ilc pass 0" in err and "ilc pass 2" in err
    open_doc, doc = (json.loads((tmp_path / f).read_text()) for f in ("open.json", "ilc.json"))
    assert set(doc) - set(open_doc) == {"passes"} and set(open_doc) <= set(doc)
    assert len(doc["passes"]) == 3 and set(REQUIRED_KEYS) <= set(doc)
    assert doc["passes"][0]["mean_error_m"] == pytest.approx(open_doc["mean_error_m"], rel=0.05)
    m = [p["mean_error_m"] for p in doc["passes"]]
    assert m[0] > 3e-3 and m[2] < 0.1 * m[0] and doc["mean_error_m"] == pytest.approx(m[2])
    np.testing.assert_allclose(doc["commands"], doc["passes"][2]["commands"])
    assert doc["info"]["closed_loop"]["mode"] == "ilc" and read_result(tmp_path / "ilc.json")["targets"].shape == (4, 3)
    assert not (tmp_path / "ilc.json.points.csv").exists()


@pytest.mark.parametrize(
    "flags, message",
    [
        (["--closed-loop", "ilc", "--passes", "0"], "--passes"),
        (["--closed-loop", "feedback", "--gain", "2.5"], "--gain"),
        (["--passes", "3"], "--closed-loop"),
    ],
)
def test_track_cli_bad_closed_loop_flags(tmp_path, capsys, flags, message):
    argv = ["track", "--model", "data/model_sim_three_cable.npz", "--trajectory", "circle", *flags]
    assert main([*argv, "--out", str(tmp_path / "x.json")]) == 2
    assert message in capsys.readouterr().err


def test_closed_loop_through_the_hardware_path(three_cable, tmp_path):
    """``track --rig hardware:RIG.toml --closed-loop ilc --passes 2`` against the emulated servo
    bus and NatNet server (real time): the body is linear, 15 % stiffer and rotated from the
    shipped model's linearisation and 2.7 mm off, so open loop misses and one ILC pass closes most of it."""
    from lab.learn.models import load_model
    from lab.rig.emulators import EmulatedBench
    from lab.rig.emulators.bodies import KinematicBody

    model = load_model("data/model_real_three_cable.npz")
    u_c = np.array([1.0, 0.8, 0.8])
    p_c, J = model.predict_and_jacobian(u_c)
    J_body = 1.15 * WRONG @ J
    body = KinematicBody(p_c - J_body @ u_c + [0.001, 0.002, -0.0015], J_body, profile_velocity_rad_s=4.0)
    targets = np.array([p_c, p_c + [0.0, 0.004, -0.003]])
    write_trajectory_csv(tmp_path / "two.csv", targets)
    with EmulatedBench(three_cable, body) as bench:
        cfg = bench.write_config(tmp_path / "rig.toml")
        argv = ["track", "--rig", f"hardware:{cfg}", "--model", "data/model_real_three_cable.npz"]
        argv += ["--trajectory", str(tmp_path / "two.csv"), "--closed-loop", "ilc", "--passes", "2"]
        assert main([*argv, "--out", str(tmp_path / "hw.json")]) == 0
    doc = json.loads((tmp_path / "hw.json").read_text())
    assert doc["info"]["rig"]["kind"] == "hardware" and len(doc["passes"]) == 2
    m = [p["mean_error_m"] for p in doc["passes"]]
    assert m[0] > 1e-3 and m[1] < 0.4 * m[0]
    truth = body.p_rest_W + np.array(doc["commands"]) @ body.J_W.T  # the body's own tip
    np.testing.assert_allclose(doc["achieved"], truth, atol=1e-4)


def test_an_unconstrained_correction_is_the_damped_pseudo_inverse_step(three_cable):
    """Inside C and within the step limit the QP step is ``alpha J+ e``; the damped
    pseudo-inverse agrees with the least-squares solution of the stacked system."""
    from lab.tracking.closed_loop import damped_pinv

    model = Linear(C, WRONG @ B)
    u = np.array([1.0, 0.8, 0.9])
    target, measured = C + B @ u + [0.0002, 0.001, -0.0008], C + B @ u
    corr = Correction(gain=0.7, max_step_rad=5.0, damping=0.05)
    got = correct_command(CommandSet.from_robot(three_cable), model, u, target, measured, corr)
    J = WRONG @ B
    lam = 0.05 * np.linalg.svd(J, compute_uv=False)[0]
    stacked = np.linalg.lstsq(np.vstack([J, lam * np.eye(3)]), np.concatenate([target - measured, np.zeros(3)]))[0]
    np.testing.assert_allclose(got, u + 0.7 * stacked, atol=1e-12)
    np.testing.assert_allclose(damped_pinv(J, 0.05) @ (target - measured), stacked, atol=1e-12)
    capped = correct_command(
        CommandSet.from_robot(three_cable), model, u, target, measured, Correction(0.7, 0.05, max_step_rad=0.05)
    )
    assert np.abs(capped - u).max() == pytest.approx(0.05)
    step = capped - u  # shortened along the same direction
    np.testing.assert_allclose(step / np.linalg.norm(step), stacked / np.linalg.norm(stacked), atol=1e-6)


def test_pass_table_and_figure(three_cable, tmp_path):
    """Result files -> one row per pass (the numbers of the files) -> the figure (log y, one
    line per model and trajectory in each mode's panel); an open-loop file is refused."""
    from lab.studies.closed_loop_table import pass_rows
    from lab.tracking.track import TrackResultError, run_trajectory, write_result
    from lab.viz.closed_loop import plot_closed_loop

    targets = C + U_IN[:3] @ B.T
    for mode, label in (("ilc", "real"), ("feedback", "sim"), ("ilc", "sim")):
        solver = IKSolver(Linear(C + 0.001, WRONG @ B), CommandSet.from_robot(three_cable))
        with LinearRig(three_cable) as rig:
            res = run_closed_loop(rig, solver, targets, mode=mode, passes=3, name="tri")
        write_result(tmp_path / f"{mode}_{label}.json", res, {"model": f"data/model_{label}_three_cable.npz"})
    rows = pass_rows(tmp_path)
    assert len(rows) == 9 and {r["model"] for r in rows} == {"real", "sim"}
    doc = json.loads((tmp_path / "feedback_sim.json").read_text())
    fb = [r for r in rows if r["mode"] == "feedback"]
    assert [r["pass"] for r in fb] == [0, 1, 2] and fb[0]["trajectory"] == "tri"
    assert [r["mean_error_m"] for r in fb] == [p["mean_error_m"] for p in doc["passes"]]
    assert [r["max_error_m"] for r in fb] == [p["max_error_m"] for p in doc["passes"]]
    fig, axes = plot_closed_loop(rows)
    assert len(axes) == 2 and all(ax.get_yscale() == "log" for ax in axes)
    assert len(axes[0].get_lines()) == 2 + 2  # two runs, two goal lines
    np.testing.assert_allclose(axes[1].get_lines()[0].get_ydata(), [100 * r["mean_error_m"] for r in fb])
    with LinearRig(three_cable) as rig:
        write_result(
            tmp_path / "open.json",
            run_trajectory(rig, IKSolver(Linear(C, B), CommandSet.from_robot(three_cable)), targets),
        )
    with pytest.raises(TrackResultError, match="not a closed-loop"):
        pass_rows(tmp_path)


def test_targets_at_the_safety_limit_are_split_from_the_rest(three_cable, tmp_path):
    """at_limit: a motor at u_max or a safety sum at its cap (three-cable: 6.5 rad over all
    three); final_pass_by_limit splits the last pass's errors by it."""
    from lab.studies.closed_loop_table import at_limit, final_pass_by_limit

    cap = three_cable.safety_limits[0].max_sum_over_u_max * three_cable.u_max_rad
    u = np.array([[1.0, 1.0, 1.0], [3.0, 0.0, 0.0], [cap / 3, cap / 3, cap / 3], [2.0, 2.0, cap - 4.0 - 0.01]])
    assert at_limit(three_cable, u).tolist() == [False, True, True, False]
    assert at_limit(three_cable, u, tol_rad=0.02).tolist() == [False, True, True, True]
    targets = np.zeros((4, 3))
    achieved = np.array([[1e-4, 0, 0], [3e-4, 0, 0], [0, 5e-4, 0], [0, 0, 2e-4]])
    final = {"commands": u.tolist(), "achieved": achieved.tolist(), "errors_m": [0.0] * 4, "mean_error_m": 0.0}
    doc = {"targets": targets.tolist(), **final, "max_error_m": 0.0, "timings": {}, "passes": [final]}
    (tmp_path / "r.json").write_text(json.dumps(doc))
    split = final_pass_by_limit(tmp_path / "r.json", three_cable)
    assert split["n"] == 4 and split["n_at_limit"] == 2
    assert split["mean_inside_m"] == pytest.approx(1.5e-4) and split["mean_at_limit_m"] == pytest.approx(4e-4)
    (tmp_path / "open.json").write_text(json.dumps({**doc, "passes": []}))
    with pytest.raises(TrackResultError, match="not a closed-loop"):
        final_pass_by_limit(tmp_path / "open.json", three_cable)


def test_a_short_dropout_grows_the_window_instead_of_skipping(three_cable):
    """0.4 s of the 0.5 s window occluded: the window grows until half of it is valid, the
    correction uses the exact tip; the same dropout without growing (max_window_s = window_s)
    skips it."""
    model = Linear(C + 0.001, WRONG @ B)
    targets = C + U_IN[:2] @ B.T
    for max_window_s, skipped in ((2.0, 0), (0.5, 1)):
        solver = IKSolver(model, CommandSet.from_robot(three_cable))
        with LinearRig(three_cable, dark={0}, dark_for_s=0.4) as rig:
            res = run_closed_loop(rig, solver, targets, passes=2, correction=Correction(max_window_s=max_window_s))
        assert res.passes[0]["n_skipped"] == skipped
        moved = not np.array_equal(res.passes[1]["commands"][0], res.passes[0]["commands"][0])
        assert moved == (skipped == 0)
    with pytest.raises(Exception, match="max_window_s"):
        Correction(window_s=1.0, max_window_s=0.5)
