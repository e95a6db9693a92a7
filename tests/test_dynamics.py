"""Trajectories at speed: the relaxation filter's inversion, the twin in
continuous time, fit-dynamics, streamed tracking open loop vs feed-forward, its CLI and the
hardware path."""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from lab.cli import main
from lab.dynamics.relaxation import Relaxation, load_relaxation
from lab.rig.mocap_model import MocapModel
from lab.rig.twin import AsBuiltBody, TwinRig

DATA = Path(__file__).parents[1] / "data"
MODEL = str(DATA / "model_real_three_cable.npz")
COARSE = {"n_rings": 2, "n_axial": 8}
COARSE_FLAGS = ["--n-rings", "2", "--n-axial", "8"]


def coarse_rig(robot, seed=0, noise=True):
    rig = TwinRig(robot, seed=seed, body=AsBuiltBody(robot, None, **COARSE))
    if not noise:
        rig.mocap = MocapModel(rig.frame_rate_hz, 0.0, 0.0, 1)
    return rig


def defects_filter(defects) -> Relaxation:
    return Relaxation([defects.tau_fast_s, defects.tau_slow_s], [1 - defects.slow_fraction, defects.slow_fraction])


# --- the inversion on a known filter ----------------------------------------------------------
def smooth_path(t):
    """A circle of 3 cm at 0.2 Hz whose radius ramps in smoothly over the first 3 s (m)."""
    ramp = np.clip(t / 3.0, 0, 1)
    s = ramp**3 * (10 - 15 * ramp + 6 * ramp**2)
    w = 2 * np.pi * 0.2 * t
    return np.column_stack([0.184 + 0 * t, 0.03 * s * np.cos(w), 0.03 * s * np.sin(w) - 0.006])


def test_inverse_of_a_known_filter_makes_it_follow_a_smooth_path():
    relax = Relaxation([0.4, 2.5], [0.7, 0.3])
    t = np.arange(0, 15, 0.05)
    p_des = smooth_path(t)
    p_in = relax.invert(t, p_des)
    t_fine = np.arange(0, t[-1], 1 / 120)  # between the knots too
    follow = np.linalg.norm(relax.response(t, p_in, t_fine) - smooth_path(t_fine), axis=1)
    assert follow.max() < 5e-6  # 5 um on a 3 cm circle
    # what it corrects: the filter alone lags and shrinks the circle by centimetres
    naive = np.linalg.norm(relax.response(t, p_des, t_fine) - smooth_path(t_fine), axis=1)
    assert naive[t_fine > 5].mean() > 0.01
    # the pre-compensated equilibrium leads: a larger circle
    r_in = np.linalg.norm(p_in[t > 5, 1:] - [0, -0.006], axis=1)
    assert r_in.min() > 0.035
    # and it is the inverse of *this* filter: another filter's inverse misses by millimetres
    wrong = Relaxation([0.5, 2.5], [0.7, 0.3]).invert(t, p_des)
    assert np.linalg.norm(relax.response(t, wrong, t_fine) - smooth_path(t_fine), axis=1).max() > 1e-3


def test_target_at_is_periodic_and_linear_between_points():
    from lab.tracking.stream import default_n_periods, target_at

    pts = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    assert np.allclose(
        target_at(pts, 4.0, [0, 1, 0.5, 3.5, 4.0, 9.0]), [pts[0], pts[1], [0.5, 0, 0], [0, 0.5, 0], pts[0], pts[1]]
    )
    assert default_n_periods(2) == 5 and default_n_periods(5) == 3 and default_n_periods(8) == 2
    assert default_n_periods(20) == 2


# --- the twin in continuous time -----------------------------------------------------------------
def test_twin_integrates_motors_play_and_lag_at_the_frame_rate(three_cable):
    """A slow sinusoid streamed at 20 Hz through the twin: the frames are the relaxation filter
    of the quasi-static equilibria of the commands. Exactly (to rounding), when the reference
    follows the play and each motor's travel; within 0.25 mm mean when it uses the streamer's
    model (settled tips from reset, reached one command period after sending) -- a lag
    integrated twice, at a wrong rate or without the motors' travel is far outside."""
    rig = coarse_rig(three_cable, noise=False)
    body, d = rig.body, rig.defects
    tick = 2 * math.pi / d.ticks_per_rev
    r, h, v = three_cable.spool_radius_m, np.asarray(d.play_m, float), d.profile_velocity_rad_s
    dt, n = 0.05, 120
    t_cmd = np.r_[0.0, 1.0 + np.arange(n - 1) * dt]  # 1 s to reach the first command, then 20 Hz
    phase = 2 * np.pi * np.maximum(t_cmd - 1.0, 0) / 4.0 + np.array([[0.0], [2.1], [4.2]])
    u = np.rint((1.2 + 0.6 * np.sin(phase.T)) / tick) * tick
    ts, ps = [], []
    for k in range(n):
        assert rig.now() == pytest.approx(t_cmd[k])
        rig.send(u[k])
        for f in rig.frames(120 if k == 0 else 6):
            ts.append(f.t_s), ps.append(f.p_tip_W)
    ts, ps = np.array(ts), np.array(ps)
    relax = defects_filter(d)
    # the reference: play operator, motors at constant speed, equilibrium linear while they turn
    y, u_prev, p_prev = np.zeros(3), np.zeros(3), body.equilibria.tip(np.zeros(3))
    tk, pk = [0.0], [p_prev]
    for k in range(n):
        y = np.clip(y, r * u[k] - h, r * u[k] + h)
        p, travel = body.equilibria.tip(y), np.max(np.abs(u[k] - u_prev)) / v
        assert k == 0 or travel < dt  # each command is reached before the next
        tk += [t_cmd[k], t_cmd[k] + travel]
        pk += [p_prev, p]
        p_prev, u_prev = p, u[k]
    assert np.abs(relax.response(tk, pk, ts) - ps).max() < 1e-9

    qs = np.array([body.quasi_static_tip(uk) for uk in u])

    def streamer(relax=relax, travel=dt):
        knots = np.r_[0.0, np.max(u[0]) / v, t_cmd[1:] + travel]
        return np.linalg.norm(relax.response(knots, np.vstack([pk[0], qs]), ts) - ps, axis=1).mean()

    assert streamer() < 2.5e-4
    assert streamer(Relaxation(relax.tau_s * 1.2, relax.weight)) > 1e-3  # lag integrated at 100 Hz for 120
    assert streamer(travel=0.0) > 1e-3  # equilibrium jumping at the command
    twice = relax.response(ts, relax.response(tk, pk, ts), ts)
    assert np.linalg.norm(twice - ps, axis=1).mean() > 5e-3


# --- fit-dynamics ----------------------------------------------------------------------------------
def test_probe_plan_is_allowed_and_reproducible(three_cable):
    from lab.capture.dynamics_probe import probe_plan

    a, b = probe_plan(three_cable, 3, 4, 10), probe_plan(three_cable, 3, 4, 10)
    assert np.array_equal(a.u_motor, b.u_motor) and len(a.u_motor) == 15
    assert np.all(three_cable.is_safe(a.u_motor))
    assert a.kinds[:4] == ("step",) * 4 and a.kinds[-1] == "step"
    assert np.all((a.hold_s[4:14] >= 0.3) & (a.hold_s[4:14] <= 1.5)) and np.all(a.hold_s[:4] == 10.0)
    assert not np.array_equal(probe_plan(three_cable, 4, 4, 10).u_motor, a.u_motor)


def test_fit_recovers_the_twins_lag(three_cable):
    from lab.capture.dynamics_probe import probe_plan, run_probe
    from lab.dynamics.relaxation_fit import fit_stream

    rig = coarse_rig(three_cable)
    relax, report = fit_stream(run_probe(rig, probe_plan(three_cable, 0, 4, 20)), 2)
    d = rig.defects
    assert relax.tau_s == pytest.approx([d.tau_fast_s, d.tau_slow_s], rel=0.05)
    assert relax.weight == pytest.approx([1 - d.slow_fraction, d.slow_fraction], abs=0.03)
    assert report["rms_m"] < 3 * d.noise_sigma_m


def test_fit_dynamics_cli_writes_a_model(three_cable, tmp_path):
    out = tmp_path / "dyn.npz"
    args = ["fit-dynamics", "--rig", "twin:random:2", "--out", str(out), "--n-steps", "3", "--n-random", "12"]
    assert main([*args, *COARSE_FLAGS]) == 0
    relax = load_relaxation(out)
    from lab.asbuilt import RANDOM

    d = RANDOM.defects(three_cable, 2)
    assert relax.tau_s == pytest.approx([d.tau_fast_s, d.tau_slow_s], rel=0.1)
    with np.load(out) as z:
        meta = json.loads(str(z["metadata"]))
    assert meta["robot"] == "three-cable" and meta["rig"]["family"]["robot_seed"] == 2
    assert meta["plan"]["n_steps"] == 3 and meta["fit"]["rms_m"] > 0 and "fit-dynamics" in meta["command"]


@pytest.mark.parametrize(
    "flags, message",
    [
        (["--rig", "sim"], "no dynamics"),
        (["--modes", "0"], "--modes"),
        (["--n-steps", "0"], "--n-steps"),
        (["--step-hold-s", "-1"], "--step-hold-s"),
        (["--step-hold-s", "1e9"], "--step-hold-s must be at most 600 s"),
        (["--n-random", "100000"], "--n-random must be at most 10000"),
        (["--rig", "hardware:/nonexistent/rig.toml"], "rig.toml"),
        (["--rig", "hardware"], "configuration file"),
        (["--robot", "nope"], "nope"),
        (["--rig", "twin:random:2", "--n-rings", "0"], "--n-rings"),
    ],
)
def test_fit_dynamics_bad_input_exits_2(tmp_path, capsys, flags, message):
    out = tmp_path / "d.npz"
    assert main(["fit-dynamics", *flags, "--out", str(out)]) == 2
    assert message in capsys.readouterr().err and not out.exists()


def test_fit_dynamics_exits_1_when_the_rig_fails(three_cable, tmp_path, capsys, monkeypatch):
    from lab.rig.base import RigError

    class Failing(TwinRig):
        n = 0

        def _send(self, u_motor):
            Failing.n += 1
            if Failing.n > 3:
                raise RigError("servo 2 stopped answering")
            super()._send(u_motor)

    monkeypatch.setattr(
        "lab.rig.make_rig",
        lambda *a, **k: Failing(three_cable, body=AsBuiltBody(three_cable, None, **COARSE)),
    )
    out = tmp_path / "d.npz"
    assert main(["fit-dynamics", "--out", str(out), "--n-steps", "2", "--n-random", "4", "--step-hold-s", "1"]) == 1
    assert "servo 2 stopped answering" in capsys.readouterr().err and not out.exists()


def test_fit_dynamics_never_overwrites_its_inputs(tmp_path, capsys):
    robot = tmp_path / "robot.npz"
    robot.write_bytes(b"x")
    assert main(["fit-dynamics", "--robot", str(robot), "--out", str(robot)]) == 2
    assert robot.read_bytes() == b"x" and "refusing to overwrite" in capsys.readouterr().err
    assert main(["fit-dynamics", "--out", str(tmp_path / "d.txt")]) == 2


# --- streaming ---------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def solver(three_cable):
    from lab.control.ik import IKSolver
    from lab.learn.models import load_model

    return IKSolver.for_model(load_model(MODEL), three_cable)


@pytest.fixture(scope="module")
def streamed(three_cable, solver):
    """The 5 s circle on the coarse twin, open loop and feed-forward through its defects' filter
    (two periods after a 5 s lead-in; the model is the shipped twin's, 8.5 mm off the coarse
    twin's statics, which bounds the feed-forward: 2.7x better here, 25x on the shipped twin)."""
    from lab.asbuilt.arm import load_defects
    from lab.control.trajectories import load_trajectory
    from lab.tracking.stream import stream_trajectory

    relax = defects_filter(load_defects(None, three_cable))
    out = {}
    for mode, r in (("open-loop", None), ("feed-forward", relax)):
        out[mode] = stream_trajectory(
            coarse_rig(three_cable), solver, load_trajectory("circle"), 5.0, relax=r, n_periods=2, lead_in_s=5.0
        )
    return out


def test_feed_forward_beats_open_loop_on_a_5_s_circle(streamed):
    ol, ff = streamed["open-loop"], streamed["feed-forward"]
    assert ol.mean_error_m > 0.01  # the lag shrinks and delays the circle by ~2 cm
    assert ff.mean_error_m < ol.mean_error_m / 2
    assert ol.mode == "open-loop" and ff.mode == "feed-forward" and ff.n_periods == 2
    # one row per valid frame of the last period (120 Hz, occlusions left out)
    assert 0.8 * 600 < len(ff.errors_m) <= 600 and np.all(np.isfinite(ff.achieved_W))
    assert ff.t_s.min() >= 0 and ff.t_s.max() < 5.0
    # open loop: the equilibria are the targets; feed-forward: a larger circle
    k = ol.knots
    assert np.allclose(k.p_in_W, k.p_des_W)
    assert np.ptp(ff.knots.p_in_W[:, 1]) > 1.2 * np.ptp(k.p_des_W[:, 1])


def test_streamed_result_file(streamed, tmp_path):
    from lab.tracking.track import read_result, write_result

    path = write_result(tmp_path / "s.json", streamed["feed-forward"], {"model": MODEL})
    doc = read_result(path)
    assert doc["mean_error_m"] == pytest.approx(streamed["feed-forward"].mean_error_m)
    assert doc["mode"] == "feed-forward" and doc["period_s"] == 5.0 and doc["dynamic_model"]["tau_s"] == [0.4, 2.5]
    assert len(doc["knots"]["t_s"]) == 2 * 5 * 20 + 1 and doc["targets"].shape == doc["achieved"].shape
    assert doc["commands"].shape == (len(doc["errors_m"]), 3)


def test_track_period_cli_streams_and_refuses_bad_flags(tmp_path, capsys):
    dyn = tmp_path / "dyn.npz"
    Relaxation([0.4, 2.5], [0.7, 0.3]).save(dyn)
    base = ["track", "--model", MODEL, "--rig", "twin", "--trajectory", "circle", *COARSE_FLAGS]
    out = tmp_path / "s.json"
    fast = ["--period-s", "3", "--n-periods", "1", "--lead-in-s", "1", "--command-rate-hz", "10"]
    assert main([*base, *fast, "--dynamic-model", str(dyn), "--out", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert doc["mode"] == "feed-forward" and doc["info"]["dynamic_model_path"] == str(dyn)
    assert doc["command_rate_hz"] == 10 and len(doc["knots"]["t_s"]) == 31
    for flags, message in [
        (["--dynamic-model", str(dyn)], "need --period-s"),
        (["--period-s", "0.1"], "--period-s"),
        (["--period-s", "5", "--closed-loop", "ilc"], "--closed-loop"),
        (["--period-s", "5", "--dynamic-model", str(tmp_path / "none.npz")], "no such dynamic-model"),
        (["--period-s", "5", "--dynamic-model", MODEL], "not a readable dynamic-model"),
        (["--period-s", "5", "--n-periods", "0"], "--n-periods"),
        (["--period-s", "5", "--command-rate-hz", "0"], "--command-rate-hz"),
        (["--period-s", "5", "--lead-in-s", "1e9"], "--lead-in-s must be at most 600 s"),
        (["--period-s", "5", "--max-spread-mm", "-1"], "--max-spread-mm is not used in a streamed run"),
        (["--period-s", "5", "--posture-weight", "1"], "--posture-weight is not used in a streamed run"),
    ]:
        assert main([*base, *flags, "--out", str(tmp_path / "bad.json")]) == 2, flags
        assert message in capsys.readouterr().err
    assert main([*base, "--period-s", "5", "--dynamic-model", str(dyn), "--out", str(dyn)]) == 2


def on_virtual_time(monkeypatch, bench):
    """Open every ``--rig hardware:RIG.toml`` of a command run in this process on ``bench``'s
    virtual clock (``make_rig`` itself gives none: it is the production path)."""
    from lab.rig.hardware import HardwareRig

    opened = HardwareRig.from_config.__func__
    options = bench.rig_options()
    virtual = classmethod(lambda cls, path, robot: opened(cls, path, robot, **options))
    monkeypatch.setattr(HardwareRig, "from_config", virtual)


def test_streams_through_the_hardware_path(three_cable, solver, tmp_path, monkeypatch):
    """The real dynamixel-sdk and NatNet client against the emulated bench on its virtual clock:
    through the CLI's --rig hardware:RIG.toml, then through the API to look at the servos.
    Every frame of the scored period is read (120 Hz for 2 s), whatever the machine's load,
    and the result says so."""
    from lab.control.trajectories import load_trajectory
    from lab.rig.emulators import EmulatedBench
    from lab.rig.hardware import HardwareRig
    from lab.tracking.stream import stream_trajectory

    dyn = tmp_path / "dyn.npz"
    relax = Relaxation([0.3, 2.0], [0.8, 0.2])
    relax.save(dyn)
    out = tmp_path / "hw.json"
    with EmulatedBench(three_cable, virtual_time=True) as bench:
        cfg = bench.write_config(tmp_path / "rig.toml")
        with monkeypatch.context() as m:
            on_virtual_time(m, bench)
            flags = ["--period-s", "2", "--n-periods", "1", "--lead-in-s", "0.5", "--dynamic-model", str(dyn)]
            argv = ["track", "--model", MODEL, "--rig", f"hardware:{cfg}", "--trajectory", "circle", *flags]
            assert main([*argv, "--out", str(out)]) == 0
        doc = json.loads(out.read_text())
        assert doc["info"]["rig"]["kind"] == "hardware" and doc["mode"] == "feed-forward"
        pace = doc["info"]["pace"]
        assert pace["expected_frames"] == 240 and pace["achieved_rate_hz"] == pytest.approx(120.0, rel=0.01)
        assert pace["n_late_gaps"] == 0 and pace["n_commands_late"] == 0 and not pace["behind"]
        assert len(doc["errors_m"]) == pace["n_frames"] and 238 <= pace["n_frames"] <= 241
        with HardwareRig.from_config(cfg, three_cable, **bench.rig_options()) as rig:
            res = stream_trajectory(
                rig, solver, load_trajectory("circle"), 1.0, relax=relax, n_periods=1, lead_in_s=0.2
            )
            goal = bench.body.u_goal_rad.copy()
    assert np.allclose(goal, res.knots.u_motor[-1], atol=2 * 2 * math.pi / 4096)  # the last command arrived
    assert 118 <= len(res.errors_m) <= 121 and np.all(np.isfinite(res.achieved_W))


def test_fit_dynamics_through_the_hardware_path(three_cable, tmp_path, monkeypatch):
    """fit-dynamics with a tiny plan on --rig hardware:RIG.toml: the real dynamixel-sdk and
    NatNet client against the emulated bench driving the coarse twin's body, on the bench's
    virtual clock; the lag comes out. The body's foam is made quicker (0.1 s / 0.6 s) so that
    a 3 s hold shows all of a step."""
    import dataclasses

    from lab.asbuilt.arm import load_defects
    from lab.rig.emulators import EmulatedBench

    out = tmp_path / "dyn.npz"
    quick_foam = dataclasses.replace(load_defects(None, three_cable), tau_fast_s=0.1, tau_slow_s=0.6)
    with EmulatedBench(three_cable, AsBuiltBody(three_cable, quick_foam, **COARSE), virtual_time=True) as bench:
        cfg = bench.write_config(tmp_path / "rig.toml")
        on_virtual_time(monkeypatch, bench)
        plan = ["--n-steps", "1", "--n-random", "2", "--step-hold-s", "3"]
        assert main(["fit-dynamics", "--rig", f"hardware:{cfg}", *plan, "--out", str(out)]) == 0
    relax = load_relaxation(out)
    assert relax.tau_s == pytest.approx([0.1, 0.6], rel=0.3) and relax.weight == pytest.approx([0.7, 0.3], abs=0.1)
    with np.load(out) as z:
        meta = json.loads(str(z["metadata"]))
    assert meta["rig"]["kind"] == "hardware"
    assert meta["pace"]["achieved_rate_hz"] == pytest.approx(120.0, rel=0.01) and meta["pace"]["n_late_gaps"] == 0


# --- falling behind: a starved loop stops and says what it missed ------------------------------------
def starve(monkeypatch, skip: int):
    """Make the twin a machine that falls behind: each frame read comes after ``skip`` others
    it never saw (the frames a busy process drops), on the twin's own clock."""
    from lab.rig.twin import TwinRig

    read = TwinRig.next_frame

    def late_frame(self):
        for _ in range(skip):
            read(self)
        return read(self)

    monkeypatch.setattr(TwinRig, "next_frame", late_frame)


@pytest.mark.parametrize(
    "skip, streamed",
    [(39, "read 5 of 240 frames (2.1 %, 2.5 Hz of 120 Hz)"), (2, "read 79 of 240 frames (32.9 %, 39.5 Hz of 120 Hz)")],
)
def test_a_starved_stream_exits_1_and_says_what_it_missed(tmp_path, capsys, monkeypatch, skip, streamed):
    """A stream that reads one frame in 40 (or in 3) exits 1 with the frames it read, the
    frames a result needs and no result file; unstarved, the same run exits 0."""
    starve(monkeypatch, skip)
    out = tmp_path / "s.json"
    base = ["track", "--model", MODEL, "--rig", "twin", "--trajectory", "circle", *COARSE_FLAGS]
    fast = ["--period-s", "2", "--n-periods", "1", "--lead-in-s", "0.5", "--command-rate-hz", "10", "--out", str(out)]
    assert main([*base, *fast]) == 1
    err = capsys.readouterr().err
    assert "the machine fell behind" in err and streamed in err and "a result needs at least 120 frames" in err
    assert "Traceback" not in err and not out.exists()


def test_a_starved_fit_dynamics_exits_1_and_writes_nothing(three_cable, tmp_path, capsys, monkeypatch):
    out = tmp_path / "dyn.npz"
    plan = ["--n-steps", "1", "--n-random", "1", "--step-hold-s", "2", *COARSE_FLAGS, "--out", str(out)]
    starve(monkeypatch, 11)  # 10 Hz of 120
    assert main(["fit-dynamics", *plan]) == 1
    err = capsys.readouterr().err
    assert "the machine fell behind: the probe read" in err and "Hz of 120 Hz" in err and "Nothing was written" in err
    assert not out.exists()
    monkeypatch.undo()
    assert main(["fit-dynamics", *plan]) == 0
    with np.load(out) as z:
        pace = json.loads(str(z["metadata"]))["pace"]
    assert pace["achieved_rate_hz"] == pytest.approx(120.0) and pace["n_late_gaps"] == 0


# --- the period curve and its figures -----------------------------------------------------------------
def test_period_curve_file_and_figures(streamed, tmp_path):
    from lab.studies.period_curve import read_period_curve, read_traces, write_period_curve, write_traces
    from lab.viz.dynamics import plot_period_curve, plot_streamed_trajectory

    rows = [
        {"rig": rig, "period_s": p, "mode": mode, "mean_error_m": e, "max_error_m": 2 * e, "n_periods": 2,
         "n_knots_unreachable": 0, "max_motor_speed_rad_s": 1.0, "tau_s": "", "weight": ""}
        for rig in ("twin", "twin:random:1")
        for p in (2, 5, 20)
        for mode, e in (("open-loop", 0.02 / p**0.5), ("feed-forward", 0.001))
    ]  # fmt: skip
    path = tmp_path / "curve.csv"
    write_period_curve(path, rows, {"command": "test"})
    back = read_period_curve(path)
    assert [r["mean_error_m"] for r in back] == pytest.approx([r["mean_error_m"] for r in rows])
    assert json.loads((tmp_path / "curve.csv.json").read_text())["command"] == "test"
    ax = plot_period_curve(back)
    assert ax.get_xscale() == "log" and ax.get_yscale() == "log" and len(ax.get_lines()) == 4 + 2
    ax2 = plot_streamed_trajectory({"open loop": streamed["open-loop"], "feed-forward": streamed["feed-forward"]})
    assert len(ax2.get_lines()) == 3
    ax2.figure.savefig(tmp_path / "traj.png")
    write_traces(tmp_path / "traces.csv", streamed)
    traces = read_traces(tmp_path / "traces.csv")
    assert traces["feed-forward"]["mean_error_m"] == pytest.approx(streamed["feed-forward"].mean_error_m, abs=1e-7)
    assert len(plot_streamed_trajectory(traces).get_lines()) == 3
    import matplotlib.pyplot as plt

    plt.close("all")


def test_cached_period_curve_meets_the_goal_where_the_model_is_the_robots_own():
    """data/period_curve.csv (benchmarks/bench_period_curve.py): at T = 5 s the feed-forward
    is >= 3x better than the quasi-static open loop wherever the quasi-static model is the
    robot's own; the figures draw the cache."""
    from lab.studies.period_curve import read_period_curve, read_traces
    from lab.viz.dynamics import plot_period_curve, plot_streamed_trajectory

    rows = read_period_curve(DATA / "period_curve.csv")
    at5 = {(r["rig"], r["model"], r["mode"]): r["mean_error_m"] for r in rows if r["period_s"] == 5.0}
    own = {"twin": "model_real_three_cable.npz"} | {
        f"twin:random:{s}": f"model_real_three_cable_random{s}.npz" for s in (1, 2)
    }
    for rig, model in own.items():
        assert at5[(rig, model, "open-loop")] >= 3 * at5[(rig, model, "feed-forward")], rig
    plot_period_curve(rows)
    plot_streamed_trajectory(read_traces(DATA / "stream_circle_T5.csv"))
    import matplotlib.pyplot as plt

    plt.close("all")
