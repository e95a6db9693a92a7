"""The shipped pneumatic robots run through the FEM: the pneumatic arm (three chambers in a
gmsh-meshed cylinder, Yeoh silicone) and the PneuNet finger (one cavity of a CAD file).

Each solves from rest under pressure, its tip Jacobian dx/du (Pa) agrees with central
differences of solves (``helpers.fd_jacobian``), a volume-controlled arm holding the volume
a pressure produced returns that pressure's equilibrium, and the workspace shapes fit the
reachable tip positions.
"""

import dataclasses

import numpy as np
import pytest
from helpers import fd_jacobian

from lab.control import fitted_shape
from lab.description import load_robot
from lab.fem import ArmFEM, Yeoh, solve_static
from lab.fem.actuators.chamber_volume import VolumeChamberActuator

ROOT = __import__("pathlib").Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def arm():
    return ArmFEM(load_robot("pneumatic-arm"))


def test_pneumatic_arm_is_yeoh_with_three_chambers(arm):
    assert arm.input_names == ("pressure_pa[top]", "pressure_pa[lower-left]", "pressure_pa[lower-right]")
    assert type(arm.body).__name__ == "ChamberedBody" and isinstance(arm.elastic, Yeoh)
    V0 = arm.actuators[0].V0_m3
    geometric = np.pi * 0.0045**2 * 0.18
    assert np.all((V0 < geometric) & (V0 > 0.8 * geometric))  # a polygonal section inside the circle


def test_pneumatic_arm_bends_away_from_a_chamber_and_its_jacobian_matches_solves(arm):
    rest = solve_static(arm, np.zeros(3))
    u = np.array([1.2e5, 0.3e5, 0.2e5])
    sol = solve_static(arm, u, rest.q, sensitivity=True, tol_step_m=1e-10)
    top = solve_static(arm, np.array([1.2e5, 0.0, 0.0]), rest.q)
    assert top.p_tip_W[2] < rest.p_tip_W[2] - 1e-3  # the top chamber lengthens the top: the tip goes down

    def tip(v):
        return solve_static(arm, v, sol.q, tol_step_m=1e-10).p_tip_W

    J_fd = fd_jacobian(tip, u, h=200.0)
    scale = np.abs(sol.J_tip_u).max()
    assert np.max(np.abs(sol.J_tip_u - J_fd)) < 2e-3 * scale


def test_a_volume_controlled_arm_holds_the_pressure_equilibrium(arm):
    robot = load_robot("pneumatic-arm")
    chambers = tuple(
        dataclasses.replace(c, control="volume", pressure_max_pa=None, volume_max_m3=5e-6) for c in robot.chambers
    )
    by_volume = ArmFEM(dataclasses.replace(robot, chambers=chambers))
    assert isinstance(by_volume.actuators[0], VolumeChamberActuator)
    p = np.array([0.8e5, 0.0, 0.4e5])
    by_p = solve_static(arm, p, tol_step_m=1e-10)
    x = arm.to_nodes(by_p.q)
    act = by_volume.actuators[0]
    injected = arm.actuators[0].volumes(x) - act.V0_m3 + p * act.V0_m3 / act.bulk_modulus_pa
    by_v = solve_static(by_volume, injected, by_p.q, tol_step_m=1e-10)
    np.testing.assert_allclose(act.pressures(by_volume.to_nodes(by_v.q), injected), p, rtol=1e-4, atol=5.0)
    assert np.max(np.abs(by_v.q - by_p.q)) < 1e-7


def test_pneunet_finger_from_a_cad_file_curls_under_pressure():
    robot = load_robot(ROOT / "examples" / "robots" / "pneunet.toml")
    fem = ArmFEM(robot)
    assert fem.marker_names == ("tip", "middle") and robot.input_units == ("Pa",)
    rest = solve_static(fem, np.zeros(1))
    sol = solve_static(fem, np.array([1e5]), rest.q)
    assert sol.y_W[0, 2] < rest.y_W[0, 2] - 2e-3  # the chambers on top lengthen it: it curls down
    grown = fem.actuators[0].volumes(fem.to_nodes(sol.q)) / fem.actuators[0].V0_m3
    assert grown[0] > 1.2


def test_fitted_shapes_lie_in_the_reachable_section():
    rng = np.random.default_rng(0)
    yz = rng.uniform(-0.01, 0.01, (200, 2)) + [0.004, -0.02]
    reach = np.column_stack([0.2 + 1e-3 * rng.standard_normal(200), yz])
    for name in ("circle", "square", "rose"):
        pts = fitted_shape(name, reach, fill=0.9)
        assert np.allclose(pts[:, 0], np.median(reach[:, 0]))
        assert np.all(np.abs(pts[:, 1:] - [0.004, -0.02]) <= 0.01)
    circle = fitted_shape("circle", reach, fill=1.0)
    radius = np.linalg.norm(circle[:, 1:] - circle[:, 1:].mean(axis=0), axis=1)
    assert 0.008 < radius.max() <= 0.0101
