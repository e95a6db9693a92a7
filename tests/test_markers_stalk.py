"""Markers inside the body and on stalks: linear in the nodes, rigid with the material, checked
against a finer model where the stalk is meshed."""

import dataclasses

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from lab.description import BodyShape, MarkerSpec
from lab.errors import InputError
from lab.fem import ArmFEM
from lab.fem.bodies import CylinderBody, FreeCoordinates, MeshBody, barycentric, body_of
from lab.fem.bodies.markers import stalk_marker
from lab.fem.solve.statics import solve_static

MARKERS = (
    MarkerSpec("inside", np.array([0.1, 0.0, 0.005])),
    MarkerSpec("stalk", np.array([0.15, 0.0, 0.035])),  # 15 mm above the top surface
    MarkerSpec("ring", np.array([0.2, 0.025, 0.0])),  # beside the tip
)


@pytest.fixture
def robot(three_cable):
    return dataclasses.replace(three_cable, markers=MARKERS)


def test_the_markers_come_tip_first_in_the_description_s_order(robot, three_cable):
    body = CylinderBody(robot, n_rings=2, n_axial=8)
    markers = body.markers()
    assert list(markers) == ["tip", "inside", "stalk", "ring"]
    nodes, weights = barycentric(body.mesh, three_cable.p_tip_marker_W)  # today's tip, exactly
    assert np.array_equal(markers["tip"].nodes, nodes[0]) and np.array_equal(markers["tip"].weights, weights[0])
    assert len(markers["inside"].nodes) == 4 and np.all(markers["inside"].weights >= 0)
    for name in ("stalk", "ring"):
        m = markers[name]
        assert len(m.nodes) >= 16 and m.weights.sum() == pytest.approx(1.0, abs=1e-12)
        assert np.allclose(m.position(body.mesh.X_W), dict((k.name, k.position_m) for k in MARKERS)[name])


def test_a_stalk_marker_is_exact_for_affine_and_rigid_motions(robot):
    body = body_of(robot, n_rings=2, n_axial=8)
    X = body.mesh.X_W
    rng = np.random.default_rng(1)
    F, c = np.eye(3) + 0.3 * rng.standard_normal((3, 3)), rng.standard_normal(3)
    Q = Rotation.from_rotvec([0.3, -0.7, 1.1]).as_matrix()
    for m, spec in zip(list(body.markers().values())[1:], MARKERS):
        assert np.allclose(m.position(X @ F.T + c), F @ spec.position_m + c, atol=1e-12)
        assert np.allclose(m.position(X @ Q.T + c), Q @ spec.position_m + c, atol=1e-12)


def test_markers_are_linear_in_the_free_coordinates(robot):
    fem = ArmFEM(robot, n_rings=2, n_axial=8)
    coords = FreeCoordinates.of(fem.body)
    q = fem.rest_q() + 1e-3 * np.random.default_rng(2).standard_normal(fem.n_free)
    for name, m in fem.markers.items():
        S = coords.point_matrix(m)
        const = m.position(fem.X_W) - S @ fem.rest_q()
        assert np.allclose(S @ q + const, m.position(fem.to_nodes(q)), atol=1e-14), name


def test_a_marker_beyond_a_stalk_s_reach_is_refused_naming_it(robot, three_cable):
    far = dataclasses.replace(robot, markers=MARKERS[:1] + (MarkerSpec("far", np.array([0.1, 0.0, 0.2])),))
    with pytest.raises(InputError, match=r"'markers\[1\].position_m'.*farther than a stalk reaches"):
        CylinderBody(far, n_rings=2, n_axial=8).markers()
    body = CylinderBody(three_cable, n_rings=2, n_axial=8)
    with pytest.raises(InputError, match="'tip_marker.position_m'"):
        stalk_marker(body.mesh, [0.5, 0.0, 0.0], "tip_marker.position_m", 0.1)


def test_a_via_point_outside_the_body_is_refused_naming_the_cable(three_cable):
    cable = dataclasses.replace(three_cable.cables[0], via_points_m=np.array([[0.1, 0.0, 0.015], [0.15, 0.0, 0.03]]))
    robot = dataclasses.replace(three_cable, cables=(cable,) + three_cable.cables[1:])
    with pytest.raises(InputError, match="cable 'top' via point 1"):
        ArmFEM(robot, n_rings=2, n_axial=8)


def test_a_stalk_marker_follows_a_meshed_stalk(three_cable, tmp_path, monkeypatch):
    """The cylinder with a marker on a 15 mm stalk vs. the cylinder with the stalk meshed (a
    1 cm square post, same foam) and the marker inside it, hanging under gravity."""
    monkeypatch.setenv("LAB_CACHE_DIR", str(tmp_path / "cache"))
    L, R, h = 0.2, 0.02, 0.015
    P = np.array([0.15, 0.0, R + h])
    plain = f'SetFactory("OpenCASCADE");\nCylinder(1) = {{0, 0, 0, {L}, 0, 0, {R}}};\n'
    post = f"Box(2) = {{0.145, -0.005, 0.015, 0.01, 0.01, {R + h + 0.003 - 0.015}}};\n"
    files = {"plain": plain, "post": plain + post + "BooleanUnion{ Volume{1}; Delete; }{ Volume{2}; Delete; }\n"}
    at = {}
    for name, text in files.items():
        (tmp_path / f"{name}.geo").write_text(text)
        shape = BodyShape("mesh", mesh_file=str(tmp_path / f"{name}.geo"), mesh_size_m=0.006)
        robot = dataclasses.replace(three_cable, body_shape=shape, markers=(MarkerSpec("s", P),))
        fem = ArmFEM(robot, body=MeshBody(robot))
        assert len(fem.markers["s"].nodes) == (4 if name == "post" else 16)
        x = fem.to_nodes(solve_static(fem, [0.0, 0.0, 0.0]).q)
        at[name] = fem.markers["s"].position(x)
        if name == "plain":  # the same point carried along by translation only, no rotation
            X_a = np.array([0.15, 0.0, R])
            nodes, w = MeshBody(robot).embed(X_a - [0, 0, 1e-4], "base")
            translated = P + w[0] @ x[nodes[0]] - (X_a - [0, 0, 1e-4])
    moved = np.linalg.norm(at["post"] - P)
    err = np.linalg.norm(at["plain"] - at["post"])
    assert moved > 5e-3
    assert err < 0.03 * moved  # measured 1.1 % at 6 mm elements, 0.5 % at 4 mm
    assert err < 0.2 * np.linalg.norm(translated - at["post"])  # the stalk's rotation matters, and is there
