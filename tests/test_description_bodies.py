"""The description's bodies, tendon controls and markers: parsing, hashes, inputs, and the
FEM built from them.

The shipped robots keep their hashes (new optional fields left at their defaults do not
count). A robot may mix angle- and tension-controlled cables: each input keeps its cable's
place in u, in its own unit and range, and the equilibrium under the tensions that an
all-angle robot's cables carry at some angles is that robot's equilibrium. Its sensitivity
dq/du matches central differences of solves (``helpers.fd_jacobian``).
"""

import dataclasses
import tomllib
from pathlib import Path

import numpy as np
import pytest
from helpers import fd_jacobian

from lab.description import ROBOTS_DIR, load_robot, parse_robot
from lab.errors import InputError
from lab.fem import ArmFEM, solve_static

EXAMPLES = Path(__file__).resolve().parent.parent / "examples" / "robots"
MESH = dict(n_rings=1, n_axial=6)


def three_cable_data() -> dict:
    return tomllib.loads((ROBOTS_DIR / "three-cable.toml").read_text())


def mixed(tension_max_n: float = 50.0) -> dict:
    """The three-cable arm with its lower cables pulled by tension."""
    data = three_cable_data()
    for c in data["cables"][1:]:
        c["control"], c["tension_max_n"] = "tension", tension_max_n
    data["safety"]["limits"][0]["cables"] = [0]
    return data


def test_shipped_robots_keep_their_hashes():
    # The hashes the as-built families and datasets pin: the new fields must not move them.
    assert load_robot("three-cable").sha256.startswith("8396156cad2098d9")
    assert load_robot("six-cable").sha256.startswith("5e38c193c3e4fbeb")
    robot = load_robot("three-cable")
    assert robot.body_shape.shape == "cylinder" and robot.markers == () and robot.all_angle
    assert robot.input_units == ("rad",) * 3 and np.array_equal(robot.u_upper, [3.0] * 3)
    assert robot.marker_names == ("tip",) and robot.output_columns == ["x", "y", "z"]


def test_tapered_tentacle_with_markers_and_tensions():
    robot = load_robot(EXAMPLES / "tentacle.toml")
    assert robot.body_shape.shape == "tapered" and robot.length_m == 0.30 and robot.radius_m == 0.030
    assert robot.radius_at(0.175) == pytest.approx(0.027 + (0.010 - 0.027) * 0.5)
    assert robot.input_units == ("N", "N") and np.array_equal(robot.u_upper, [1.5, 1.5])
    assert robot.spool_radius_m is None and robot.u_max_rad is None and robot.safety_limits == ()
    assert robot.marker_names == ("tip", "upper", "middle", "lower")
    assert robot.output_columns[3:6] == ["upper_x", "upper_y", "upper_z"]
    # One offset per station: the tendons follow the taper at 75 % of the radius.
    via = robot.cables[0].via_points_m
    assert np.allclose(np.hypot(via[:, 1], via[:, 2]) / robot.radius_at(via[:, 0]), 0.75, atol=0.02)
    # A hash of its own, and the tension bound is part of it.
    other = dataclasses.replace(
        robot, cables=(dataclasses.replace(robot.cables[0], tension_max_n=9.0),) + robot.cables[1:]
    )
    assert robot.sha256 != other.sha256


def test_a_two_station_profile_is_the_cylinder():
    data = three_cable_data()
    body = data["body"]
    data["body"] = {"shape": "tapered", "profile_m": [[0.0, body["radius_m"]], [body["length_m"], body["radius_m"]]]}
    tapered = parse_robot(data)
    cylinder = load_robot("three-cable")
    assert (tapered.length_m, tapered.radius_m) == (cylinder.length_m, cylinder.radius_m)
    for a, b in zip(tapered.cables, cylinder.cables):
        assert np.array_equal(a.via_points_m, b.via_points_m)


def test_mixed_controls_check_each_input_in_its_unit():
    robot = parse_robot(mixed(tension_max_n=5.0))
    assert robot.input_units == ("rad", "N", "N") and np.array_equal(robot.u_upper, [3.0, 5.0, 5.0])
    assert robot.is_safe([3.0, 5.0, 5.0]) and not robot.is_safe([3.0, 5.5, 0.0])
    with pytest.raises(InputError, match=r"input 1 \(cable 'lower-left'\) 5.5 N outside \[0, 5.0\] N"):
        robot.check_command([1.0, 5.5, 0.0])
    fem = ArmFEM(robot, **MESH)
    assert fem.input_names == ("u_motor[top]", "tension_n[lower-left]", "tension_n[lower-right]")
    with pytest.raises(InputError, match="outside"):
        fem.check_input([3.5, 0.0, 0.0])


def test_a_safety_rule_over_a_tension_is_refused():
    data = mixed()
    data["safety"]["limits"][0]["cables"] = [0, 1]
    with pytest.raises(InputError, match=r"safety.limits\[0\].cables' must list angle-controlled cables only"):
        parse_robot(data)


def test_tensions_hold_the_equilibrium_of_the_angles_that_make_them():
    angle_robot = load_robot("three-cable")
    fem_angle = ArmFEM(angle_robot, **MESH)
    u = np.array([1.2, 0.6, 0.0])
    sol = solve_static(fem_angle, u, tol_force_n=1e-10)
    T = fem_angle.cable_tensions(fem_angle.to_nodes(sol.q), u)
    assert T[1] > 0.1 and T[2] == 0.0
    fem_mixed = ArmFEM(parse_robot(mixed()), **MESH)
    sol_mixed = solve_static(fem_mixed, np.array([u[0], T[1], T[2]]), tol_force_n=1e-10)
    assert np.max(np.abs(sol_mixed.q - sol.q)) < 1e-8
    assert np.allclose(sol_mixed.y_W[0], sol.p_tip_W, atol=1e-8)


def test_mixed_sensitivity_matches_differences_of_solves():
    fem = ArmFEM(parse_robot(mixed()), **MESH)
    u = np.array([1.0, 0.8, 0.3])
    sol = solve_static(fem, u, sensitivity=True, tol_force_n=1e-11)

    def tip(v):
        return solve_static(fem, v, sol.q, tol_force_n=1e-11).p_tip_W

    J_fd = fd_jacobian(tip, u, 1e-4)
    assert np.allclose(sol.J_tip_u, J_fd, rtol=1e-4, atol=1e-7)
    assert np.array_equal(sol.J_y_u, sol.J_tip_u)  # the tip is the only marker


def test_an_all_tension_robot_needs_no_actuation_table():
    data = mixed()
    data["cables"][0] |= {"control": "tension", "tension_max_n": 50.0}
    del data["actuation"], data["safety"]
    robot = parse_robot(data)
    fem = ArmFEM(robot, **MESH)
    assert [a.kind for a in fem.actuators] == ["tendons_tension"] and robot.u_max_rad is None
    assert solve_static(fem, np.array([0.0, 2.0, 2.0])).converged
