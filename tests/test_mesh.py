import numpy as np
import pytest

from lab.fem.bodies.mesh import barycentric, cylinder_mesh, load_mesh, save_mesh


@pytest.mark.parametrize("n_rings, n_axial", [(1, 3), (2, 5), (3, 4)])
def test_cylinder_mesh_volume_and_closed_surface(n_rings, n_axial):
    L, R = 0.2, 0.02
    mesh = cylinder_mesh(L, R, n_rings, n_axial)
    vol = mesh.volumes()
    assert np.all(vol > 0)
    n = 6 * n_rings  # the outer ring is a regular n-gon inscribed in the circle
    assert vol.sum() == pytest.approx(0.5 * n * R**2 * np.sin(2 * np.pi / n) * L, rel=1e-12)
    assert mesh.n_nodes == (1 + 3 * n_rings * (n_rings + 1)) * (n_axial + 1)
    tris = mesh.surface_triangles()
    # Closed, consistently wound surface: every directed edge appears once, reversed once.
    edges = np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]])
    fwd = {tuple(e) for e in edges}
    assert len(fwd) == len(edges) and all((b, a) in fwd for a, b in fwd)
    # Outward: the divergence theorem gives the volume with the right sign.
    X = mesh.X_W[tris]
    assert np.einsum("fi,fi->", X[:, 0], np.cross(X[:, 1], X[:, 2])) / 6 == pytest.approx(vol.sum())


def test_barycentric_embedding_reproduces_points():
    mesh = cylinder_mesh(0.2, 0.02, 2, 8)
    pts = np.array([[0.2, 0, 0], [0.04, 0.0, 0.015], [0.1, -0.01, 0.005]])
    nodes, w = barycentric(mesh, pts)
    assert np.allclose(np.einsum("pk,pkd->pd", w, mesh.X_W[nodes]), pts, atol=1e-12)
    assert np.all(w >= 0) and np.allclose(w.sum(1), 1)
    with pytest.raises(ValueError, match="outside"):
        barycentric(mesh, [[0.3, 0, 0]])


def test_meshio_round_trip(tmp_path):
    mesh = cylinder_mesh(0.2, 0.02, 1, 4)
    save_mesh(tmp_path / "arm.vtu", mesh)
    back = load_mesh(tmp_path / "arm.vtu")
    assert np.allclose(back.X_W, mesh.X_W) and np.array_equal(back.tets, mesh.tets)
