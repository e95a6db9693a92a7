"""Bodies from mesh and CAD files: reading, meshing, the cache, every check, and the FEM on them."""

import dataclasses

import meshio
import numpy as np
import pytest

from lab.description import BodyShape
from lab.description.geometry import MeshFileError, clamped_nodes, file_sha256, locate, read_body_mesh
from lab.fem import ArmFEM
from lab.fem.bodies import MeshBody, barycentric, cylinder_mesh
from lab.fem.solve.statics import solve_static

CYLINDER_GEO = """SetFactory("OpenCASCADE");
Cylinder(1) = {{0, 0, 0, {L}, 0, 0, {R}}};
Physical Volume("foam") = {{1}};
Physical Surface("base") = {{3}};
"""


@pytest.fixture(autouse=True)
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("LAB_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache" / "meshes"


def geo(tmp_path, name="cyl.geo", L=0.2, R=0.02, scale=1.0):
    path = tmp_path / name
    path.write_text(CYLINDER_GEO.format(L=L * scale, R=R * scale))
    return path


def shape(path, **kw):
    return BodyShape("mesh", mesh_file=str(path), **kw)


def write_mesh(path, X, tets, **kw):
    meshio.write(path, meshio.Mesh(X, [("tetra", np.asarray(tets))], **kw))
    return path


def test_a_gmsh_cylinder_has_the_structured_cylinder_s_volume_and_clamps_its_base(tmp_path):
    m = read_body_mesh(shape(geo(tmp_path), mesh_size_m=0.006))
    P = m.X_m[m.tets]
    vol = np.linalg.det(np.stack([P[:, 1] - P[:, 0], P[:, 2] - P[:, 0], P[:, 3] - P[:, 0]], -1)) / 6
    assert np.all(vol > 0) and m.tets.dtype == np.int64
    assert vol.sum() == pytest.approx(cylinder_mesh(0.2, 0.02, 3, 20).volumes().sum(), rel=0.03)
    assert vol.sum() == pytest.approx(np.pi * 0.02**2 * 0.2, rel=0.03)
    base = clamped_nodes(m, shape(geo(tmp_path), mesh_size_m=0.006))
    group = clamped_nodes(m, shape(geo(tmp_path), mesh_size_m=0.006, clamp=None, clamp_group="base"))
    assert base.sum() > 20 and np.array_equal(base, group) and np.all(m.X_m[base, 0] == 0)
    assert set(m.groups) == {"foam", "base"}


def test_a_millimetre_geometry_is_scaled_to_metres(tmp_path):
    m = read_body_mesh(shape(geo(tmp_path, scale=1e3), mesh_unit="mm", mesh_size_m=0.008))
    assert m.X_m[:, 0].max() == pytest.approx(0.2) and np.hypot(m.X_m[:, 1], m.X_m[:, 2]).max() == pytest.approx(0.02)


def test_the_cache_is_bit_identical_skips_gmsh_and_follows_the_file(tmp_path, cache, monkeypatch):
    import lab.description.geometry as geometry

    path = geo(tmp_path)
    s = shape(path, mesh_size_m=0.005)
    a = read_body_mesh(s)
    assert len(list(cache.glob("*.npz"))) == 1
    with monkeypatch.context() as m:  # a cache hit does not mesh (what makes it fast)
        m.setattr(geometry, "_mesh_geometry", lambda *a, **k: pytest.fail("meshed again on a cache hit"))
        b = read_body_mesh(s)
    assert np.array_equal(a.X_m, b.X_m) and np.array_equal(a.tets, b.tets)
    assert all(np.array_equal(a.groups[k], b.groups[k]) for k in a.groups)
    for f in cache.glob("*.npz"):  # a fresh mesh of the same file is the same mesh
        f.unlink()
    c = read_body_mesh(s)
    assert np.array_equal(a.X_m, c.X_m) and np.array_equal(a.tets, c.tets)
    geo(tmp_path, L=0.25)  # the file changes: meshed again
    d = read_body_mesh(s)
    assert d.X_m[:, 0].max() == pytest.approx(0.25)
    assert len(list(cache.glob("*.npz"))) == 2
    e = read_body_mesh(dataclasses.replace(s, mesh_size_m=0.008))  # the settings change: meshed again
    assert len(e.X_m) < len(d.X_m)


def test_a_description_s_file_may_not_change_under_it(tmp_path):
    path = geo(tmp_path)
    s = shape(path, mesh_size_m=0.008, mesh_sha256=file_sha256(path))
    read_body_mesh(s)
    geo(tmp_path, L=0.3)
    with pytest.raises(MeshFileError, match="changed since"):
        read_body_mesh(s)


@pytest.mark.parametrize("suffix", [".msh", ".vtu", ".vtk"])
def test_meshio_formats_are_read_as_they_are(tmp_path, suffix):
    mesh = cylinder_mesh(0.2, 0.02, 2, 6)
    path = write_mesh(tmp_path / f"arm{suffix}", mesh.X_W, mesh.tets)
    m = read_body_mesh(shape(path))
    assert np.allclose(m.X_m, mesh.X_W) and np.array_equal(m.tets, mesh.tets)


def test_a_file_wound_the_other_way_throughout_is_reoriented_and_unused_nodes_dropped(tmp_path):
    mesh = cylinder_mesh(0.2, 0.02, 1, 4)
    X = np.vstack([mesh.X_W, [[1.0, 1.0, 1.0]]])  # a stray node
    m = read_body_mesh(shape(write_mesh(tmp_path / "neg.vtu", X, mesh.tets[:, [1, 0, 2, 3]])))
    assert len(m.X_m) == mesh.n_nodes
    P = m.X_m[m.tets]
    assert np.all(np.linalg.det(np.stack([P[:, 1] - P[:, 0], P[:, 2] - P[:, 0], P[:, 3] - P[:, 0]], -1)) > 0)


def bad(tmp_path, match, field="body.mesh_file", **kw):
    with pytest.raises(MeshFileError, match=match) as err:
        read_body_mesh(shape(kw.pop("path"), **kw))
    assert f"'{field}'" in str(err.value)
    return str(err.value)


def test_every_bad_body_file_is_refused_naming_the_field_and_the_file(tmp_path):
    mesh = cylinder_mesh(0.2, 0.02, 1, 4)
    msg = bad(tmp_path, "no such file", path=tmp_path / "nope.msh")
    assert "nope.msh" in msg
    (tmp_path / "arm.stl").write_text("solid x\nendsolid x\n")
    bad(tmp_path, "unknown suffix", path=tmp_path / "arm.stl")
    bad(tmp_path, "size_m", field="mesh.size_m", path=geo(tmp_path))
    ok = write_mesh(tmp_path / "ok.vtu", mesh.X_W, mesh.tets)
    bad(tmp_path, "geometry files", field="mesh.size_m", path=ok, mesh_size_m=0.01)
    bad(tmp_path, "linear", field="mesh.order", path=ok, mesh_order=2)
    tri = tmp_path / "tri.vtu"
    meshio.write(tri, meshio.Mesh(mesh.X_W, [("triangle", mesh.tets[:, :3])]))
    bad(tmp_path, "no tetrahedra", path=tri)
    (tmp_path / "junk.msh").write_text("not a mesh")
    bad(tmp_path, "cannot read", path=tmp_path / "junk.msh")
    flipped = mesh.tets.copy()
    flipped[[3, 7]] = flipped[[3, 7]][:, [1, 0, 2, 3]]
    inv = write_mesh(tmp_path / "inv.vtu", mesh.X_W, flipped)
    assert "2 of 72 tetrahedra are inverted (wound against the others), the first is tet 3" in bad(
        tmp_path, "inverted", path=inv
    )
    X = mesh.X_W.copy()
    t = mesh.tets[5]
    X[t[3]] = X[t[:3]].mean(axis=0)  # flatten one tet onto its face (its neighbours invert or survive)
    bad(tmp_path, "degenerate|inverted", path=write_mesh(tmp_path / "flat.vtu", X, mesh.tets))
    X2 = np.vstack([mesh.X_W, mesh.X_W + [0.0, 0.1, 0.0]])
    two = np.vstack([mesh.tets, mesh.tets + mesh.n_nodes])
    assert "2 disconnected pieces" in bad(tmp_path, "disconnected", path=write_mesh(tmp_path / "two.vtu", X2, two))
    mm = write_mesh(tmp_path / "mm.vtu", mesh.X_W * 1e3, mesh.tets)
    assert 'mesh_unit = "mm"?' in bad(tmp_path, "mm", field="body.mesh_unit", path=mm)
    bad(tmp_path, "metres", field="body.mesh_unit", path=ok, mesh_unit="mm")


def test_a_degenerate_tet_is_named(tmp_path):
    X = np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1], [0.05, 0.05, 0.0]], float)
    tets = np.array([[0, 1, 2, 3], [0, 1, 4, 3]])  # node 4 lies on the plane z = 0 of nodes 0, 1: flat
    tets[1] = [0, 1, 2, 4]
    bad(tmp_path, "1 degenerate", path=write_mesh(tmp_path / "deg.vtu", X, tets))


def test_clamps_that_hold_nothing_or_name_no_group_are_refused(tmp_path):
    mesh = cylinder_mesh(0.2, 0.02, 1, 4)
    X = np.vstack([mesh.X_W, [[0.1, 0.1, 0.1]]])
    path = write_mesh(tmp_path / "g.inp", X, mesh.tets, point_sets={"stray": np.array([mesh.n_nodes])})
    m = read_body_mesh(shape(path))
    with pytest.raises(MeshFileError, match=r"'body.clamp_group'.*no physical group 'fixed'.*stray"):
        clamped_nodes(m, shape(path, clamp=None, clamp_group="fixed"))
    with pytest.raises(MeshFileError, match=r"'body.clamp_group'.*no node is clamped"):
        clamped_nodes(m, shape(path, clamp=None, clamp_group="stray"))
    with pytest.raises(MeshFileError, match=r"'body.clamp'"):
        clamped_nodes(m, shape(path, clamp=None))


def test_locate_agrees_with_barycentric_and_finds_points_outside():
    mesh = cylinder_mesh(0.2, 0.02, 3, 12)
    rng = np.random.default_rng(0)
    r, a = 0.018 * np.sqrt(rng.random(300)), 2 * np.pi * rng.random(300)
    P = np.column_stack([0.2 * rng.random(300), r * np.cos(a), r * np.sin(a)])
    tet, w = locate(mesh.X_W, mesh.tets, np.vstack([P, [[0.3, 0.0, 0.0]]]))
    assert tet[-1] == -1 and np.all(tet[:-1] >= 0)
    assert np.allclose(np.einsum("pk,pkd->pd", w[:-1], mesh.X_W[mesh.tets[tet[:-1]]]), P, atol=1e-12)
    nodes, wb = barycentric(mesh, P[:5])
    assert np.allclose(np.einsum("pk,pkd->pd", wb, mesh.X_W[nodes]), P[:5])


def test_a_cylinder_from_a_cad_file_bends_like_the_structured_cylinder(three_cable, tmp_path):
    robot = dataclasses.replace(three_cable, body_shape=shape(geo(tmp_path), mesh_size_m=0.007))
    body = MeshBody(robot)
    fem_m, fem_s = ArmFEM(robot, body=body), ArmFEM(three_cable, n_rings=3, n_axial=20)
    assert body.clamped.sum() > 10
    tips = {}
    for name, fem in (("mesh", fem_m), ("structured", fem_s)):
        x = fem.to_nodes(solve_static(fem, [0.0, 0.0, 0.0]).q)
        tips[name] = fem.tip(x) - three_cable.p_tip_marker_W
    sag = np.linalg.norm(tips["structured"])
    assert sag > 5e-3  # it hangs
    # Two discretisations of one body: linear tets are too stiff in bending, each by a few %.
    assert np.linalg.norm(tips["mesh"] - tips["structured"]) < 0.1 * sag
    with pytest.raises(Exception, match="cable 'top' via point"):
        far = dataclasses.replace(three_cable.cables[0], via_points_m=np.array([[0.1, 0.0, 0.03]]))
        ArmFEM(dataclasses.replace(robot, cables=(far,)), body=body)
