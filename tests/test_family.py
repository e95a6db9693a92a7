"""The family of emulated as-built robots (lab.asbuilt.RANDOM): seeded defects files, their
ranges, ``--rig twin:random:SEED`` and ``python -m lab defects``. Emulators run on coarse
meshes (2 rings, 4 layers)."""

import dataclasses
import math
import tomllib

import numpy as np
import pytest
from sweep import Case, run_case

from lab.asbuilt import PNEUMATIC, RANDOM
from lab.asbuilt.arm import as_built_fem, load_defects
from lab.asbuilt.draw import FIXED, RANGES
from lab.capture.protocol import Protocol
from lab.capture.session import capture
from lab.cli import main
from lab.description import ROBOTS_DIR, Cable, load_robot, shipped_robots
from lab.errors import InputError
from lab.rig import FamilyTwinRig, make_rig

SEEDS = range(40)
COARSE = dict(n_rings=2, n_axial=4)


def coarse(robot):
    return dataclasses.replace(robot, **COARSE)


def shift_components(robot, defects):
    """(radial, tangential, axial) eyelet shift (n_cables, 3) m in each cable's frame."""
    out = []
    for cable, d in zip(robot.cables, defects.cables):
        centre = cable.via_points_m[:, 1:].mean(axis=0)
        e_r = centre / np.linalg.norm(centre)
        e_t = np.array([-e_r[1], e_r[0]])
        s = d.via_shift_m
        out.append([s[1:] @ e_r, s[1:] @ e_t, s[0]])
    return np.array(out)


def field_values(robot, d) -> dict:
    """Every drawn field of a :class:`Defects` as arrays (one value per cable for cables)."""
    shifts = shift_components(robot, d)
    angle = math.degrees(math.atan2(d.gradient_direction_W[2], d.gradient_direction_W[1])) % 360
    return {
        "softness": [d.softness],
        "gradient": [d.gradient],
        "gradient_angle_deg": [angle],
        "radial_shift_m": shifts[:, 0],
        "tangential_shift_m": shifts[:, 1],
        "axial_shift_m": shifts[:, 2],
        "slack_m": d.slack_m,
        "play_m": d.play_m,
        "tau_fast_s": [d.tau_fast_s],
        "tau_slow_s": [d.tau_slow_s],
        "slow_fraction": [d.slow_fraction],
        "profile_velocity_rad_s": [d.profile_velocity_rad_s],
        "noise_sigma_m": [d.noise_sigma_m],
        "dropout_rate_hz": [d.dropout_rate_hz],
        "dropout_max_frames": [d.dropout_max_frames],
    }


def test_same_seed_same_file_and_different_seeds_differ(three_cable, tmp_path):
    a, b = tmp_path / "a.toml", tmp_path / "sub" / "b.toml"
    RANDOM.write(a, three_cable, 3)
    RANDOM.write(b, three_cable, 3)
    assert a.read_bytes() == b.read_bytes() == RANDOM.toml(three_cable, 3).encode()
    assert not list(tmp_path.rglob(".*.tmp*"))  # written atomically, nothing left over
    hashes = {RANDOM.defects(three_cable, s).sha256 for s in range(10)}
    assert len(hashes) == 10
    softness = [RANDOM.defects(three_cable, s).softness for s in range(10)]
    assert len(set(softness)) == 10


def test_round_trip_through_load_defects(three_cable, tmp_path):
    for seed in (0, 7, 123456789):
        path = tmp_path / f"d{seed}.toml"
        drawn = RANDOM.write(path, three_cable, seed, **COARSE)
        loaded = load_defects(path, three_cable)
        assert loaded.sha256 == drawn.sha256 == RANDOM.defects(three_cable, seed, **COARSE).sha256
        assert loaded.source == drawn.source and (loaded.n_rings, loaded.n_axial) == (2, 4)
        for c_l, c_d in zip(loaded.cables, drawn.cables):
            assert np.array_equal(c_l.via_shift_m, c_d.via_shift_m) and c_l.slack_m == c_d.slack_m
        text = path.read_text()
        assert f"member {seed} of the family of {RANDOM.label}s" in text and "U(0.55, 1.1)" in text


def test_ranges_respected_spread_and_wider_than_the_shipped_file(three_cable):
    shipped = load_defects(None, three_cable)
    drawn = {k: [] for k in RANGES}
    for seed in SEEDS:
        d = RANDOM.defects(three_cable, seed)
        assert d.ticks_per_rev == FIXED["ticks_per_rev"] and d.frame_rate_hz == FIXED["frame_rate_hz"]
        assert d.tau_slow_s >= d.tau_fast_s
        for k, v in field_values(three_cable, d).items():
            drawn[k] += list(v)
    ship = field_values(three_cable, shipped)
    for key, (lo, hi) in RANGES.items():
        v = np.array(drawn[key])
        tol = 1e-6 * max(1.0, abs(hi))
        assert v.min() >= lo - tol and v.max() <= hi + tol, f"{key}: {v.min()}..{v.max()} outside {lo}..{hi}"
        # the draws do spread over their range (shrinking only ever trims the eyelet shifts)
        assert v.max() - v.min() > (0.4 if "shift" in key else 0.7) * (hi - lo), key
        s = np.array(ship[key])
        assert lo <= s.min() and s.max() <= hi, f"{key}: shipped {s} outside {lo}..{hi}"
        assert hi - lo > s.max() - s.min(), f"{key}: range not wider than the shipped file's"
    assert np.allclose(ship["gradient_angle_deg"], 270.0)  # -z: the shipped arm is mounted as cast


def _held_out_robot(three_cable):
    """Five cables at odd angles, 17 mm from the axis, ending at different stations."""
    cables = []
    for i, (angle, end) in enumerate([(10, 0.2), (80, 0.2), (170, 0.15), (250, 0.2), (300, 0.1)]):
        a = math.radians(angle)
        x = np.linspace(0.03, end, 4)
        via = np.column_stack([x, np.full(4, 0.017 * math.cos(a)), np.full(4, 0.017 * math.sin(a))])
        cables.append(Cable(f"c{i}", np.array([0.0, via[0, 1], via[0, 2]]), via))
    return dataclasses.replace(three_cable, name="held-out-five", cables=tuple(cables), safety_limits=(), **COARSE)


@pytest.mark.parametrize("name", [*shipped_robots(), "held-out"])
def test_every_robot_builds_its_as_built_fem(name, three_cable):
    robot = _held_out_robot(three_cable) if name == "held-out" else coarse(load_robot(name))
    chambered = bool(getattr(robot, "chambers", ()))  # drawn by the pneumatic family, meshed by gmsh (~1 s)
    for seed in range(1 if chambered else 6):
        d = (PNEUMATIC if chambered else RANDOM).defects(robot, seed)
        assert len(d.cables) == robot.n_cables and len(d.chambers) == len(getattr(robot, "chambers", ()))
        fem = as_built_fem(robot, d)  # every eyelet inside the body and the mesh
        assert fem.mesh.n_nodes > 0
    if name == "six-cable":  # cables through the same eyelets share their shift
        d = RANDOM.defects(robot, 1)
        for long, short in ((0, 3), (1, 4), (2, 5)):
            assert np.array_equal(d.cables[long].via_shift_m, d.cables[short].via_shift_m)
            assert d.cables[long].slack_m != d.cables[short].slack_m


def test_shifts_are_shrunk_to_fit_a_one_ring_mesh(three_cable):
    robot = dataclasses.replace(three_cable, n_rings=1, n_axial=6)
    limit = 0.02 * math.cos(math.pi / 6)  # the 1-ring section: a hexagon
    for seed in SEEDS:
        d = RANDOM.defects(robot, seed)
        for cable, c in zip(robot.cables, d.cables):
            assert np.hypot(*(cable.via_points_m[:, 1:] + c.via_shift_m[1:]).T).max() < limit
    as_built_fem(robot, RANDOM.defects(robot, 5))


def test_twin_random_rig_captures(three_cable, tmp_path):
    robot = coarse(three_cable)
    u = np.array([[1.0, 0.0, 0.5], [0.0, 2.0, 1.0]])
    with make_rig("twin:random:3", robot, seed=1) as rig:
        assert isinstance(rig, FamilyTwinRig) and rig.defects.sha256 == RANDOM.defects(robot, 3).sha256
        res = capture(rig, u, tmp_path / "j.csv", Protocol(), progress=False)
        info = rig.describe()
    assert res.p_tip_W.shape == (2, 3) and np.all(np.isfinite(res.p_tip_W))
    assert info["kind"] == "twin" and info["label"] == RANDOM.label and info["family"]["robot_seed"] == 3
    assert info["defects"]["path"] == "random:3" and info["seed"] == 1
    with make_rig("twin:random:4", robot) as other:  # another robot of the family
        assert other.defects.sha256 != rig.defects.sha256


@pytest.mark.parametrize(
    "spec, words",
    [
        ("twin:random:abc", "robot seed must be a non-negative integer"),
        ("twin:random:-1", "got '-1'"),
        ("twin:random:1.5", "twin:random:SEED"),
        ("twin:random", "needs the robot's seed"),
        ("twin:random:", "needs the robot's seed"),
    ],
)
def test_bad_random_specs(spec, words, three_cable):
    with pytest.raises(InputError, match=words):
        make_rig(spec, three_cable)


def test_bad_seed_arguments(three_cable):
    for bad in (-1, 1.5, True, "3"):
        with pytest.raises(InputError, match="non-negative integer"):
            RANDOM.defects(three_cable, bad)


def test_defects_cli_writes_the_family_member(tmp_path, capsys, three_cable):
    out = tmp_path / "d.toml"
    assert main(["defects", "--random", "3", "--robot", "three-cable", "--n-rings", "2", "--out", str(out)]) == 0
    assert "twin:" in capsys.readouterr().err
    assert load_defects(out, three_cable).sha256 == RANDOM.defects(three_cable, 3, n_rings=2).sha256
    data = tomllib.loads(out.read_text())
    assert data["emulator"] == {"n_rings": 2} and "--random 3 --robot three-cable --n-rings 2" in out.read_text()
    again = tmp_path / "again.toml"
    assert main(["defects", "--random", "3", "--robot", "three-cable", "--n-rings", "2", "--out", str(again)]) == 0
    assert again.read_bytes() == out.read_bytes()


def _copy_robot(d):
    (d / "six.toml").write_bytes((ROBOTS_DIR / "six-cable.toml").read_bytes())


#: Fault-sweep rows for ``defects`` and the new capture/rig arguments (format of tests/sweep.py).
CASES = [
    Case(
        "defects-out-is-robot",
        ["defects", "--random", "1", "--robot", "{dir}/robot.toml", "--out", "{dir}/robot.toml"],
        2,
        ("is the input --robot", "refusing"),
        unchanged=("{dir}/robot.toml",),
    ),
    Case(
        "defects-negative-seed",
        ["defects", "--random", "-4", "--out", "{dir}/d.toml"],
        2,
        ("--random", ">= 0"),
        absent=("{dir}/d.toml",),
    ),
    Case(
        "defects-wrong-robot-name",
        ["defects", "--random", "1", "--robot", "no-such", "--out", "{dir}/d.toml"],
        2,
        ("unknown robot 'no-such'",),
        absent=("{dir}/d.toml",),
    ),
    Case(
        "defects-out-is-a-directory",
        ["defects", "--random", "1", "--out", "{dir}"],
        2,
        ("is a directory",),
    ),
    Case(
        "defects-mesh-zero",
        ["defects", "--random", "1", "--n-rings", "0", "--out", "{dir}/d.toml"],
        2,
        ("--n-rings must be a positive integer",),
        absent=("{dir}/d.toml",),
    ),
    Case(
        "defects-six-cable-by-path",
        ["defects", "--random", "2", "--robot", "{dir}/six.toml", "--out", "{dir}/d.toml"],
        0,
        setup=_copy_robot,
        unchanged=("{dir}/six.toml",),
        after=lambda d: load_defects(d / "d.toml", load_robot(d / "six.toml")),
    ),
    *(
        Case(
            f"capture-rig-{spec.replace(':', '-')}",
            ["capture", "--rig", spec, "--grid", "2", "--out", "{dir}/c.csv", "--no-progress"],
            2,
            (f"rig '{spec}'", "twin:random:SEED"),
            absent=("{dir}/c.csv", "{dir}/c.journal.csv"),
        )
        for spec in ("twin:random:abc", "twin:random", "twin:random:-3")
    ),
]


@pytest.mark.parametrize("case", CASES, ids=str)
def test_sweep_rows(case, tmp_path, capsys, monkeypatch):
    run_case(case, tmp_path, capsys, monkeypatch)
