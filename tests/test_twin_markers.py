"""The twin and capture on every marker, and on tension-controlled tendons.

A cylinder robot with two interior ``[[markers]]`` (a TOML in tmp_path, the three-cable arm
plus markers, so the shipped defects fit it) on the emulated as-built robot: its tip is the
tip-only robot's, bit for bit; every marker follows the same lag and the same frame error;
capture journals and returns every marker. A robot with a tension-controlled tendon: its
input is held at once in N, and the protocol's reset pulls it to half its bound.
"""

import dataclasses
import tomllib
from pathlib import Path

import numpy as np
import pytest

import lab
from lab.asbuilt.arm import default_defects_path, parse_defects
from lab.capture.markers import mean_markers, reset_command
from lab.capture.protocol import Protocol, measure
from lab.capture.session import capture
from lab.description import load_robot
from lab.rig.base import MocapFrame
from lab.rig.mocap_model import MocapModel
from lab.rig.twin import AsBuiltBody, TwinRig

MARKERS = """
[[markers]]
name = "mid"
position_m = [0.10, 0.0, 0.004]

[[markers]]
name = "ring"
position_m = [0.15, 0.006, 0.0]
"""
QUICK = Protocol()


def _robot_toml(three_cable, tmp_path, name, tension=False):
    text = (Path(lab.__file__).parent / "robots" / "three-cable.toml").read_text() + MARKERS
    if tension:  # the first cable pulled by a tension; the safety rule keeps the angle cables
        text = text.replace('name = "top"\n', 'name = "top"\ncontrol = "tension"\ntension_max_n = 2.0\n', 1)
        text = text.replace("cables = [0, 1, 2]", "cables = [1, 2]")
    path = tmp_path / name
    path.write_text(text)
    return load_robot(path)


@pytest.fixture(scope="module")
def robots(three_cable, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("robots")
    return _robot_toml(three_cable, tmp, "markers.toml"), _robot_toml(three_cable, tmp, "tension.toml", tension=True)


@pytest.fixture(scope="module")
def coarse_defects(three_cable):
    """The shipped defects on a coarse mesh (eyelets in place: the thin mesh is too thin for the shifts)."""
    d = tomllib.loads(default_defects_path(three_cable).read_text())
    for c in d["cables"]:
        c.update(via_shift_m=[0.0, 0.0, 0.0])
    d["emulator"] = {"n_rings": 2, "n_axial": 6}
    return d


def _defects(d, robot, **replace):
    return dataclasses.replace(parse_defects(d, robot), **replace)


def test_the_twin_reports_every_marker_and_its_tip_is_the_tip_only_robots(three_cable, robots, coarse_defects):
    marked = robots[0]
    assert marked.marker_names == ("tip", "mid", "ring")
    plain = TwinRig(three_cable, parse_defects(coarse_defects, three_cable), seed=4)
    rig = TwinRig(marked, parse_defects(coarse_defects, marked), seed=4)
    for r in (plain, rig):
        r.send([1.5, 0.5, 0.0])
    frames, frames0 = rig.frames(150), plain.frames(150)
    for f, f0 in zip(frames, frames0):  # the tip: bit for bit, noise and occlusions included
        assert np.array_equal(f.p_tip_W, f0.p_tip_W, equal_nan=True) and f0.markers_W is None
        assert f.markers_W.shape == (3, 3) and np.array_equal(f.markers_W[0], f.p_tip_W, equal_nan=True)
        assert np.all(np.isfinite(f.markers_W)) == f.valid  # every marker hidden with the tip
    # each marker seen with its own noise around where the body has it now
    qs = rig.body.quasi_static_markers([1.5, 0.5, 0.0])
    assert np.array_equal(qs[0], rig.body.quasi_static_tip([1.5, 0.5, 0.0]))
    last = frames[-1].markers_W
    true = rig.body.markers(rig._body_time())
    assert np.array_equal(true[0], rig.body.state(rig._body_time())[1])
    if np.all(np.isfinite(last)):
        assert np.all(np.abs(last - true) < 6 * rig.defects.noise_sigma_m)
    # the markers lie on the bent arm: the mid marker lifted less than the tip
    assert 0 < qs[1, 2] < qs[0, 2] and qs[1, 0] < qs[2, 0] < qs[0, 0]


def test_tilt_and_frame_error_move_every_marker_alike(robots, coarse_defects):
    marked = robots[0]
    clean = AsBuiltBody(marked, _defects(coarse_defects, marked))
    R_axis, offset = np.array([0.0, 0.0, 1.0]), np.array([0.003, -0.002, 0.001])
    wrong = AsBuiltBody(
        marked,
        _defects(coarse_defects, marked, frame_rotation_deg=2.0, frame_rotation_axis_W=R_axis, frame_offset_m=offset),
    )
    u = [0.0, 2.0, 0.5]
    p, q = clean.quasi_static_markers(u), wrong.quasi_static_markers(u)
    R = wrong._R_report
    assert R is not None and not np.allclose(R, np.eye(3))
    assert np.allclose(q, p @ R.T + offset, atol=1e-12)
    assert np.allclose(wrong.report_points(p), [wrong.report(pi) for pi in p], atol=1e-15)


def test_mocap_markers_keep_the_tips_stream():
    a, b = MocapModel(120.0, 1e-4, 2.0, 5, seed=9), MocapModel(120.0, 1e-4, 2.0, 5, seed=9)
    pts = np.array([[0.2, 0.0, 0.0], [0.1, 0.0, 0.0]])
    for _ in range(500):
        seen, tip = a.observe_markers(pts), b.observe(pts[0])
        assert np.array_equal(seen[0], tip, equal_nan=True)
        assert np.isnan(seen[1]).all() == np.isnan(tip).all()
    assert a.n_dropped > 0


def test_mean_markers_leaves_out_unseen_frames():
    frames = [np.array([[0.0, 0, 0], [1.0, 1, 1]]), np.array([[2.0, 0, 0], [np.nan] * 3])]
    assert np.array_equal(mean_markers(frames, 2), [[1.0, 0, 0], [1.0, 1, 1]])
    assert np.isnan(mean_markers([], 2)).all()
    tip_only = MocapFrame(0.0, np.zeros(3))  # a rig that sees the tip alone cannot capture markers
    from lab.capture.markers import frame_markers
    from lab.rig.base import RigError

    with pytest.raises(RigError, match="reports the tip alone"):
        frame_markers(tip_only, 3, "hardware")


def test_capture_journals_every_marker_on_the_twin(robots, coarse_defects, tmp_path):
    marked = robots[0]
    rig = TwinRig(marked, parse_defects(coarse_defects, marked), seed=1)
    u = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 2.0]])
    res = capture(rig, u, tmp_path / "j.csv", QUICK)
    assert res.markers == ("tip", "mid", "ring") and res.y_W.shape == (2, 9)
    assert np.array_equal(res.y_W[:, :3], res.p_tip_W)
    qs = np.array([rig.body.quasi_static_markers(ui).ravel() for ui in u])
    assert np.max(np.abs(res.y_W - qs)) < 2e-3
    header = (tmp_path / "j.csv").read_text().splitlines()
    cols = next(line for line in header if line.startswith("index,"))
    assert "z,mid_x,mid_y,mid_z,ring_x,ring_y,ring_z,settled" in cols
    again = capture(rig, u, tmp_path / "j.csv", QUICK)  # resumed: nothing new, same rows
    assert again.new_samples == 0 and np.array_equal(again.y_W, res.y_W)
    with pytest.raises(Exception, match="predictive protocol watches the tip alone"):
        capture(rig, u, tmp_path / "p.csv", Protocol(kind="predictive"))


def test_a_tension_tendon_is_held_in_newtons_on_the_twin(robots, coarse_defects):
    robot = robots[1]
    assert robot.input_units == ("N", "rad", "rad")
    assert np.array_equal(reset_command(robot, Protocol()), [1.0, 1.0, 1.0])  # half of 2 N; 1 rad
    rig = TwinRig(robot, parse_defects(coarse_defects, robot), seed=2)
    body = rig.body
    rig.send([1.5, 0.4, 0.0])
    assert rig.present_u()[0] == 1.5  # held at once, not in encoder ticks
    rest, pulled = body.quasi_static_markers([0.0, 0.0, 0.0]), body.quasi_static_markers([1.5, 0.0, 0.0])
    assert pulled[0, 2] - rest[0, 2] > 0.02  # the top tendon lifts the tip
    s = measure(rig, [1.5, 0.4, 0.0], QUICK)
    assert s.settled and s.markers_W.shape == (3, 3) and s.u_present[0] == 1.5
    assert np.max(np.abs(s.markers_W - body.quasi_static_markers([1.5, 0.4, 0.0]))) < 2e-3


def test_cable_stiffness_is_refused_on_a_robot_with_tension_tendons(robots, coarse_defects):
    from lab.asbuilt.arm import as_built_fem
    from lab.asbuilt.fields import DefectsError

    d = {**coarse_defects, "cables": [dict(c, stiffness_n_per_m=2e3) for c in coarse_defects["cables"]]}
    with pytest.raises(DefectsError, match="stiffness_n_per_m"):
        as_built_fem(robots[1], parse_defects(d, robots[1]))
