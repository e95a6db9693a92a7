"""The pneumatic family of emulated as-built robots (lab.asbuilt.PNEUMATIC, ``--rig
twin:pneumatic:SEED``, ``python -m lab defects --pneumatic SEED``): deterministic draws within
their ranges, the defects file's round trip, a capture on the emulated rig (pressures in Pa,
regulators instead of servos), the regulators' lag in the time response, and bad fields
refused by name. One member is re-meshed by gmsh per test that builds one (~5 s)."""

import copy
import math
import tomllib

import numpy as np
import pytest

from lab.asbuilt import FOAM, PNEUMATIC, RANDOM, family_member
from lab.asbuilt.arm import DefectsError, load_defects, parse_defects
from lab.asbuilt.chambered import as_built_chambers
from lab.asbuilt.pneumatic import PNEUMATIC_RANGES
from lab.capture import Protocol, capture
from lab.cli import main
from lab.description import load_robot
from lab.errors import InputError
from lab.rig import FamilyTwinRig, PneumaticBody, RigSpec, make_rig


@pytest.fixture(scope="module")
def arm():
    return load_robot("pneumatic-arm")


def test_draws_are_deterministic_within_range_and_members_differ(arm, three_cable):
    assert PNEUMATIC.toml(arm, 3) == PNEUMATIC.toml(arm, 3)
    members = [PNEUMATIC.defects(arm, s) for s in range(30)]
    assert len({d.sha256 for d in members}) == 30
    fields = {"softness": [], "gradient": [], "tilt_deg": [], "stiffness": [], "regulator_tau_s": []}
    fields |= {"regulator_dead_time_s": [], "regulator_gain": [], "offset_error_m": [], "radius_error_m": []}
    for d in members:
        for k in ("softness", "gradient", "tilt_deg"):
            fields[k].append(getattr(d, k))
        for c in d.chambers:
            for k in fields:
                if hasattr(c, k):
                    fields[k].append(getattr(c, k))
        as_built_chambers(arm, d)  # every drawn cavity keeps its walls
    for key, values in fields.items():
        lo, hi = PNEUMATIC_RANGES[key]
        v = np.array(values)
        assert v.min() >= lo - 1e-6 and v.max() <= hi + 1e-6 and v.max() - v.min() > 0.6 * (hi - lo), key
    offsets = np.array([c.regulator_offset_pa / 2e5 for d in members for c in d.chambers])
    assert np.abs(offsets).max() <= 0.015 + 1e-5
    assert RigSpec.parse("twin:pneumatic:3").label == PNEUMATIC.label == "emulated as-built robot (pneumatic family)"
    assert family_member(arm, "pneumatic:3").sha256 == members[3].sha256
    for family in (RANDOM, FOAM):  # the cable families draw eyelets and servos: refused
        with pytest.raises(InputError, match="driven by pressure chambers"):
            family.defects(arm, 0)
    with pytest.raises(InputError, match="has no pressure chambers"):
        PNEUMATIC.defects(three_cable, 0)


def test_bad_chamber_fields_are_refused_by_name(arm, three_cable):
    data = tomllib.loads(PNEUMATIC.toml(arm, 0))
    for table, key, value, words in [
        (1, "regulator_offset_pa", 5e4, "'chambers[1].regulator_offset_pa' must be a finite number in [-20000"),
        (0, "regulator_gain", 3.0, "'chambers[0].regulator_gain'"),
        (2, "radius_error_m", -0.0045, "'chambers[2].radius_error_m'"),
        (0, "stiffness", "soft", "'chambers[0].stiffness'"),
        (0, "name", "bottom", "'chambers[0].name' must be 'top'"),
    ]:
        bad = copy.deepcopy(data)
        bad["chambers"][table][key] = value
        with pytest.raises(DefectsError, match=words.replace("[", r"\[")):
            parse_defects(bad, arm)
    bad = copy.deepcopy(data)
    bad["chambers"][0]["offset_error_m"] = 0.004  # the wall to the surface below one element
    with pytest.raises(DefectsError, match="offset_error_m.*thinner than one element"):
        as_built_chambers(arm, parse_defects(bad, arm))
    missing = {k: v for k, v in data.items() if k != "chambers"}
    with pytest.raises(DefectsError, match=r"\[\[chambers\]\] must have one table per chamber"):
        parse_defects(missing, arm)
    cable = tomllib.loads(RANDOM.toml(three_cable, 0))
    cable["chambers"] = data["chambers"]
    with pytest.raises(DefectsError, match="has no chambers"):
        parse_defects(cable, three_cable)


def test_the_file_is_the_member_and_a_capture_runs_on_it(arm, tmp_path, capsys):
    out = tmp_path / "p0.toml"
    assert main(["defects", "--pneumatic", "0", "--robot", "pneumatic-arm", "--out", str(out)]) == 0
    assert "member 0 of the pneumatic family" in capsys.readouterr().err
    assert out.read_text() == PNEUMATIC.toml(arm, 0)
    assert load_defects(out, arm).sha256 == PNEUMATIC.defects(arm, 0).sha256
    with make_rig("twin:pneumatic:0", arm, seed=1) as drawn, make_rig(f"twin:{out}", arm, seed=1) as read:
        assert isinstance(drawn, FamilyTwinRig) and isinstance(drawn.body, PneumaticBody)
        assert drawn.describe()["label"] == PNEUMATIC.label and drawn.describe()["family"]["name"] == "pneumatic"
        assert np.array_equal(drawn.body.fem.mesh.X_W, read.body.fem.mesh.X_W)  # the same re-meshed cavities
        assert np.array_equal(drawn.body.state(0.0)[1], read.body.state(0.0)[1])
        u = np.array([[1.5e5, 0.0, 0.0], [0.0, 1.2e5, 1.2e5]])  # Pa
        protocol = Protocol(settle_timeout_s=20.0)
        res = capture(drawn, u, tmp_path / "j.csv", protocol, progress=False)
    assert res.p_tip_W.shape == (2, 3) and np.all(np.isfinite(res.p_tip_W))
    truth = np.array([drawn.body.quasi_static_tip(ui) for ui in u])
    assert np.abs(res.p_tip_W - truth).max() < 6e-4  # the settled tips, up to noise and slow relaxation
    assert np.linalg.norm(res.p_tip_W[0] - res.p_tip_W[1]) > 2e-3


def test_regulator_lag_and_dead_time_show_in_the_time_response(arm):
    data = tomllib.loads(PNEUMATIC.toml(arm, 1))
    for c in data["chambers"]:
        c.update(regulator_tau_s=0.2, regulator_dead_time_s=0.02, regulator_gain=1.0, regulator_offset_pa=0.0)
    data["lag"].update(tau_fast_s=0.01, tau_slow_s=0.01, slow_fraction=0.0)
    body = PneumaticBody(arm, parse_defects(data, arm))
    p0 = body.state(0.0)[1]
    goal = np.array([1.5e5, 0.0, 0.0])
    body.command(goal, 0.0)
    step = body.quasi_static_tip(goal) - p0
    assert np.linalg.norm(step) > 2e-3
    u, p = body.state(0.015)  # within the dead time: nothing yet
    assert np.all(u == 0) and np.allclose(p, p0, atol=1e-12)
    for t in (0.1, 0.22, 0.6, 2.0):
        u, p = body.state(t)
        expected = 1 - math.exp(-(t - 0.02) / 0.2)
        assert u[0] == pytest.approx(1.5e5 * expected, rel=1e-9) and np.all(u[1:] == 0)
        frac = (p - p0) @ step / (step @ step)
        assert frac == pytest.approx(expected, abs=0.06), t  # the tip follows the pressure, the body's own lag
    assert frac > 0.99
