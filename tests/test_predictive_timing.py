"""Predictive capture through the hardware path takes fewer frames than waiting (lab.rig.dynamixel).

On the emulated bench that ``python -m lab.rig.emulators`` serves (a ``KinematicBody``: no
foam lag), predicted samples used to take ~44 s each against ~4 s waited: every servo turned
at the same profile velocity, so a motor with a shorter travel stopped first and the tip
went along a bent path, up to ~6 mm from the straight ramp that the relaxation fit and the
Kalman filter assume. The fit read that miss as motion-capture noise (4-6 mm per frame, true
0) and the filter then averaged hundreds of readings. The driver now scales each servo's
speed to its travel, so every move is a straight line. All on the bench's virtual clock, and
counted in frames: nothing here depends on the machine's load.
"""

import numpy as np
import pytest

from lab.capture.protocol import Protocol
from lab.capture.session import capture
from lab.data.designs import random_commands
from lab.rig.dynamixel_units import synced_velocity_units
from lab.rig.emulators import EmulatedBench
from lab.rig.hardware import HardwareRig


def test_synced_velocities_bring_every_servo_in_together():
    v = synced_velocity_units([-2000, 500, 0, 1], 125)
    assert v.tolist() == [125, 31, 125, 1]  # 125 * 500 / 2000 = 31.25; at least 1 unit
    assert synced_velocity_units([0, 0], 125).tolist() == [125, 125]


def _open(bench, robot, tmp_path):
    cfg = bench.write_config(tmp_path / "rig.toml")
    return HardwareRig.from_config(cfg, robot, **bench.rig_options())


def test_a_move_of_unequal_travels_is_a_straight_line(three_cable, tmp_path):
    """Motors travelling 0.39, 1.50 and 1.80 rad: the tip stays within 0.2 mm of the straight
    line from start to goal all the way (0.08 mm, as speeds are whole units; unsynchronised:
    4.6 mm), and the servos' profile velocities are in proportion to their travels."""
    u = random_commands(three_cable, 1, seed=11)[0]
    with EmulatedBench(three_cable, virtual_time=True) as bench, _open(bench, three_cable, tmp_path) as rig:
        p0 = rig.wait(0.1)[-1].p_tip_W
        rig.send(u)
        frames = rig.wait(1.0)  # the move takes 1.80 rad / 3 rad/s = 0.6 s
        speeds = np.array([bench.bus.state(s.dxl_id)["profile_velocity"] for s in bench.specs])
    p1 = frames[-1].p_tip_W
    d = (p1 - p0) / np.linalg.norm(p1 - p0)
    off = [np.linalg.norm((f.p_tip_W - p0) - d * ((f.p_tip_W - p0) @ d)) for f in frames]
    assert np.linalg.norm(p1 - p0) > 0.02 and max(off) < 2e-4
    assert speeds.max() == 125 and np.allclose(speeds / 125, u / u.max(), atol=0.01)


def test_predicted_samples_on_the_emulated_bench_take_fewer_frames_than_waited_ones(three_cable, tmp_path):
    """4 samples learned by waiting, then 2 predicted: each predicted sample is confident in
    fewer frames than the fastest waited one (before: 60 s timeouts, ~7300 frames against
    ~420), the learned noise is below 1 mm per frame (before: 4.3 mm), and the predictions
    are within 0.2 mm of the body's tip."""
    u = random_commands(three_cable, 6, seed=11)
    with EmulatedBench(three_cable, virtual_time=True) as bench, _open(bench, three_cable, tmp_path) as rig:
        res = capture(rig, u, tmp_path / "j.csv", Protocol(kind="predictive", n_learn=4))
        body = bench.body
    assert res.predicted.tolist() == [False] * 4 + [True] * 2 and res.settled.all()
    assert res.n_frames[4:].max() < res.n_frames[:4].min()
    (learned,) = [info for tag, info in res.notes if tag == "relaxation"]
    assert learned["noise_sigma_m"] < 1e-3
    truth = body.p_rest_W + u @ body.J_W.T
    assert np.linalg.norm(res.p_tip_W - truth, axis=1).max() < 2e-4
    waited_s, predicted_s = res.sample_s[:4].mean(), res.sample_s[4:].mean()
    assert waited_s == pytest.approx(3.7, abs=0.5) and predicted_s < 0.6 * waited_s
