"""The tapered body: a profile's mesh, a cylinder written as a profile, and body_of."""

import dataclasses

import numpy as np
import pytest

from lab.description import BodyShape
from lab.errors import InputError
from lab.fem import ArmFEM
from lab.fem.bodies import CylinderBody, MeshBody, TaperedBody, body_of, cylinder_mesh, tapered_mesh
from lab.fem.solve.statics import solve_static


def tapered(robot, profile):
    return dataclasses.replace(robot, body_shape=BodyShape("tapered", profile_m=np.asarray(profile, float)))


@pytest.mark.parametrize("size", [(3, 20), (1, 5), (2, 7)])
def test_a_two_station_constant_profile_is_the_cylinder_bit_for_bit(size):
    a = cylinder_mesh(0.2, 0.02, *size)
    b = tapered_mesh([[0.0, 0.02], [0.2, 0.02]], *size)
    assert np.array_equal(a.X_W, b.X_W) and np.array_equal(a.tets, b.tets)


def test_a_cylinder_as_a_profile_gives_todays_tips(three_cable):
    robot = tapered(three_cable, [[0.0, three_cable.radius_m], [three_cable.length_m, three_cable.radius_m]])
    body = body_of(robot, n_rings=1, n_axial=6)
    assert isinstance(body, TaperedBody)
    fem_c, fem_t = ArmFEM(three_cable, n_rings=1, n_axial=6), ArmFEM(robot, body=body)
    assert np.array_equal(fem_c.tip_matrix().toarray(), fem_t.tip_matrix().toarray())
    for u in ([0.0, 0.0, 0.0], [1.0, 0.0, 0.3]):
        a, b = solve_static(fem_c, u), solve_static(fem_t, u)
        assert np.array_equal(a.q, b.q)
        assert np.array_equal(fem_c.tip(fem_c.to_nodes(a.q)), fem_t.tip(fem_t.to_nodes(b.q)))


def test_the_layers_follow_the_profile_and_the_volume_is_the_frustums():
    profile = np.array([[0.0, 0.03], [0.1, 0.02], [0.3, 0.01]])
    mesh = tapered_mesh(profile, 4, 30)
    X = mesh.X_W
    for x in np.unique(X[:, 0]):
        r = np.hypot(X[X[:, 0] == x, 1], X[X[:, 0] == x, 2]).max()
        assert r == pytest.approx(np.interp(x, profile[:, 0], profile[:, 1]), rel=1e-12)
    vol = mesh.volumes()
    assert np.all(vol > 0)
    frustums = sum(
        np.pi * (x1 - x0) * (r0 * r0 + r0 * r1 + r1 * r1) / 3 for (x0, r0), (x1, r1) in zip(profile[:-1], profile[1:])
    )
    assert vol.sum() == pytest.approx(frustums, rel=0.05)  # inscribed polygons, linear layers


def test_a_bad_profile_is_refused():
    with pytest.raises(InputError, match="profile"):
        tapered_mesh([[0.0, 0.02]], 2, 4)
    with pytest.raises(InputError, match="profile"):
        tapered_mesh([[0.01, 0.02], [0.2, 0.01]], 2, 4)


def test_body_of_picks_the_description_s_body(three_cable, tmp_path):
    assert type(body_of(three_cable, n_rings=1, n_axial=4)) is CylinderBody
    mesh_robot = dataclasses.replace(three_cable, body_shape=BodyShape("mesh", mesh_file=str(tmp_path / "b.msh")))
    with pytest.raises(InputError, match="n_rings"):
        body_of(mesh_robot, n_rings=2)
    assert MeshBody.kind == "mesh" and TaperedBody.kind == "tapered"


def test_a_tapered_tentacle_hangs_and_its_markers_come_tip_first(three_cable):
    robot = tapered(three_cable, [[0.0, 0.02], [0.2, 0.007]])
    robot = dataclasses.replace(robot, p_tip_marker_W=np.array([0.2, 0.0, 0.0]), cables=robot.cables[:1])
    robot = dataclasses.replace(
        robot,
        cables=(dataclasses.replace(robot.cables[0], via_points_m=np.array([[0.05, 0.0, 0.01], [0.15, 0.0, 0.006]])),),
    )
    from lab.description import MarkerSpec

    robot = dataclasses.replace(robot, markers=(MarkerSpec("mid", np.array([0.1, 0.0, 0.0])),))
    fem = ArmFEM(robot, body=body_of(robot, n_rings=2, n_axial=10))
    assert list(fem.markers) == ["tip", "mid"]
    sol = solve_static(fem, [0.0], check_command=False)
    x = fem.to_nodes(sol.q)
    assert fem.tip(x)[2] < -1e-3  # it sags
    assert fem.markers["mid"].position(x)[2] > fem.tip(x)[2]
