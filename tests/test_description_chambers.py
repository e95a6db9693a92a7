"""Chambers and Yeoh silicone in the description: the inputs after the cables, their units and
ranges, the checks of ``check_command``, the Yeoh law's small-strain match, the hash, and the
material the FEM builds from it (scaled by a per-tet modulus alike in every coefficient)."""

import dataclasses
import tomllib

import numpy as np
import pytest

from lab.description import ROBOTS_DIR, Chamber, DescriptionError, load_robot, parse_robot
from lab.errors import InputError
from lab.fem.materials import NeoHookeanMaterial, YeohMaterial
from lab.fem.model_material import description_material


def arm_data():
    return tomllib.loads((ROBOTS_DIR / "pneumatic-arm.toml").read_text())


def test_pneumatic_arm_inputs_are_its_chambers_in_pascals():
    robot = load_robot("pneumatic-arm")
    assert robot.n_cables == 0 and robot.n_inputs == 3
    assert robot.input_names == ("top", "lower-left", "lower-right")
    assert robot.input_units == ("Pa", "Pa", "Pa")
    assert robot.u_lower.tolist() == [0, 0, 0] and robot.u_upper.tolist() == [200e3] * 3
    assert not robot.all_angle and robot.n_rings is None and robot.body_shape.mesh_size_m == 0.005
    assert robot.check_command([0.0, 1e4, 2e5]).tolist() == [0.0, 1e4, 2e5]
    with pytest.raises(InputError, match=r"input 1 \(chamber 'lower-left'\) -5.0 Pa outside \[0, 200000.0\] Pa"):
        robot.check_command([0.0, -5.0, 0.0])
    with pytest.raises(InputError, match="finite"):
        robot.check_command([0.0, np.nan, 0.0])
    assert robot.is_safe(np.array([[0, 0, 2e5], [0, 0, 2.1e5]])).tolist() == [True, False]


def test_yeoh_small_strain_match_and_bulk_modulus():
    data = arm_data()
    robot = parse_robot(data)
    c10, nu = 110e3, 0.45
    assert robot.material_model == "yeoh" and robot.yeoh_c_pa == (110e3, 20e3, 0.0)
    assert robot.youngs_modulus_pa == pytest.approx(4 * c10 * (1 + nu)) and robot.poisson_ratio == nu
    mat = dict(data["material"])
    del mat["poisson_ratio"]
    kappa = 2 * (2 * c10) * (1 + nu) / (3 * (1 - 2 * nu))
    mat["bulk_modulus_pa"] = kappa
    other = parse_robot({**data, "material": mat})
    assert other.poisson_ratio == pytest.approx(nu, rel=1e-12)
    assert other.bulk_modulus_pa == kappa and other.sha256 != robot.sha256


def test_description_material_scales_every_yeoh_coefficient():
    robot = load_robot("pneumatic-arm")
    E = robot.youngs_modulus_pa * np.array([1.0, 1.5])
    law = description_material(robot, E)
    assert isinstance(law, YeohMaterial)
    np.testing.assert_allclose(law.c10_pa, [110e3, 165e3])
    np.testing.assert_allclose(law.c20_pa, [20e3, 30e3])
    np.testing.assert_allclose(law.kappa_pa, 1.5 ** np.arange(2) * YeohMaterial(110e3, poisson_ratio=0.45).kappa_pa)
    foam = load_robot("three-cable")
    assert isinstance(description_material(foam, foam.youngs_modulus_pa), NeoHookeanMaterial)


def test_chamber_fields_enter_the_hash_and_cable_robots_keep_theirs():
    robot = load_robot("pneumatic-arm")
    moved = dataclasses.replace(robot.chambers[0], offset_m=0.009)
    assert dataclasses.replace(robot, chambers=(moved, *robot.chambers[1:])).sha256 != robot.sha256
    assert load_robot("three-cable").sha256.startswith("8396156cad2098d9")


def test_volume_chamber_bounds_and_units():
    data = arm_data()
    chambers = [dict(c) for c in data["chambers"]]
    for key in ("pressure_max_pa",):
        chambers[0].pop(key)
    chambers[0].update(control="volume", volume_max_m3=2e-6, volume_min_m3=-1e-6)
    robot = parse_robot({**data, "chambers": chambers})
    c = robot.chambers[0]
    assert isinstance(c, Chamber) and c.unit == "m^3" and c.bounds == (-1e-6, 2e-6)
    assert robot.input_units == ("m^3", "Pa", "Pa") and robot.u_lower.tolist() == [-1e-6, 0, 0]
    robot.check_command([-1e-6, 0.0, 0.0])
    with pytest.raises(InputError, match="chamber 'top'"):
        robot.check_command([-2e-6, 0.0, 0.0])


def test_chambers_and_cables_share_u_cables_first():
    data = tomllib.loads((ROBOTS_DIR / "three-cable.toml").read_text())
    arm = arm_data()
    chamber = dict(arm["chambers"][0], name="core", angle_deg=0.0, offset_m=0.0, radius_m=0.004)
    mesh = {"size_m": 0.005}
    robot = parse_robot({**data, "chambers": [chamber], "mesh": mesh})
    assert robot.input_names == ("top", "lower-left", "lower-right", "core")
    assert robot.input_units == ("rad", "rad", "rad", "Pa")
    assert robot.u_upper.tolist() == [3.0, 3.0, 3.0, 200e3]


def test_a_cable_and_a_chamber_may_not_share_a_name():
    data = tomllib.loads((ROBOTS_DIR / "three-cable.toml").read_text())
    chamber = dict(arm_data()["chambers"][0], angle_deg=0.0, offset_m=0.0, radius_m=0.004)
    with pytest.raises(DescriptionError, match="must be unique together"):
        parse_robot({**data, "chambers": [chamber], "mesh": {"size_m": 0.005}})


@pytest.mark.parametrize("name", ["pneumatic-arm", "examples/robots/pneunet.toml"])
def test_a_written_description_reads_back_the_same(name):
    from pathlib import Path

    from lab.transfer.robot_toml import robot_toml

    robot = load_robot(Path(__file__).resolve().parents[1] / name if "/" in name else name)
    again = parse_robot(tomllib.loads(robot_toml(robot)))
    assert again.sha256 == robot.sha256 and again.chambers == robot.chambers
