"""Tetrahedral meshes of the arm body, and embedding points in them.

The built-in mesher makes a structured cylinder along +x: each cross-section is a
disk of concentric rings (ring k has 6k nodes), triangulated ring by ring, extruded
into prisms, and each prism split into three tetrahedra. The split follows the
global node order, so neighbouring prisms cut their shared quad face along the same
diagonal and the mesh is conforming. Users with their own geometry can load any
tetrahedral mesh with :func:`load_mesh` (anything ``meshio`` reads).
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from lab.errors import InputError
from lab.files import format_bytes


@dataclass(frozen=True)
class TetMesh:
    """A tetrahedral mesh at rest, positively oriented (det[X1-X0, X2-X0, X3-X0] > 0).

    Attributes
    ----------
    X_W : ndarray, shape (N, 3)
        Rest node positions in frame W, m.
    tets : ndarray of int, shape (M, 4)
        Node indices of each tetrahedron.
    """

    X_W: np.ndarray
    tets: np.ndarray

    @property
    def n_nodes(self) -> int:
        """Number of nodes N."""
        return len(self.X_W)

    def volumes(self) -> np.ndarray:
        """Rest volume of every tet.

        Returns
        -------
        ndarray, shape (M,)
            Signed volumes, m^3 (positive for an oriented mesh).
        """
        X = self.X_W[self.tets]
        return np.linalg.det(np.stack([X[:, 1] - X[:, 0], X[:, 2] - X[:, 0], X[:, 3] - X[:, 0]], axis=-1)) / 6.0

    def surface_triangles(self) -> np.ndarray:
        """The faces on the mesh's boundary.

        Returns
        -------
        ndarray of int, shape (F, 3)
            Node indices of each boundary triangle, wound counter-clockwise seen from outside.
        """
        t = self.tets
        # Faces opposite vertex 0..3, each wound so its normal points out of the tet.
        faces = np.concatenate([t[:, [1, 2, 3]], t[:, [0, 3, 2]], t[:, [0, 1, 3]], t[:, [0, 2, 1]]])
        key = np.sort(faces, axis=1)
        _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
        return faces[counts[inverse.ravel()] == 1]


def _disk(radius: float, n_rings: int) -> tuple[np.ndarray, np.ndarray]:
    """Concentric-ring disk: points (P, 2) and counter-clockwise triangles (T, 3)."""
    pts = [np.zeros((1, 2))]
    ring_start = [0]
    for k in range(1, n_rings + 1):
        n = 6 * k
        a = 2 * np.pi * np.arange(n) / n
        pts.append(radius * k / n_rings * np.column_stack([np.cos(a), np.sin(a)]))
        ring_start.append(ring_start[-1] + (1 if k == 1 else 6 * (k - 1)))
    tris = []
    for k in range(1, n_rings + 1):
        n_in, n_out = (1 if k == 1 else 6 * (k - 1)), 6 * k
        s_in, s_out = ring_start[k - 1], ring_start[k]
        # March around both rings by angle, always advancing the ring whose next node
        # comes first; this strip triangulation has no overlaps and no slivers.
        i, j = (1 if n_in == 1 else 0), 0  # the centre node is a fan, it never advances
        while i < n_in or j < n_out:
            a_in = (i + 1) / n_in if n_in > 1 else np.inf
            a_out = (j + 1) / n_out
            if j < n_out and (i >= n_in or a_out <= a_in):
                tris.append((s_in + i % n_in, s_out + j % n_out, s_out + (j + 1) % n_out))
                j += 1
            else:
                tris.append((s_in + i % n_in, s_out + j % n_out, s_in + (i + 1) % n_in))
                i += 1
    return np.concatenate(pts), np.asarray(tris)


#: Memory of an FEM solve per tetrahedron (element Hessians, the sparse pattern, the
#: factorisation), bytes, and a fixed part: measured peak RSS of ArmFEM + one static solve
#: with sensitivities was 17, 10.6 and 10.1 kB per tet on meshes of 3,240, 25,920 and
#: 92,160 tets (three-cable arm, PARDISO); 12 kB covers them with some room.
BYTES_PER_TET = 12_000
BYTES_FIXED = 100_000_000


def cylinder_counts(n_rings: int, n_axial: int) -> tuple[int, int]:
    """Nodes and tets of :func:`cylinder_mesh` without building it."""
    return (1 + 3 * n_rings * (n_rings + 1)) * (n_axial + 1), 18 * n_rings**2 * n_axial


def available_memory_bytes() -> int:
    try:
        import psutil

        return int(psutil.virtual_memory().available)
    except ImportError:  # Linux without psutil
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")


def check_mesh_size(n_rings, n_axial, available_bytes: int | None = None) -> int:
    """Refuse mesh sizes that are not positive integers or whose FEM would not fit in the
    memory available now (InputError with the estimate); returns the estimate in bytes."""
    for name, v in (("n_rings", n_rings), ("n_axial", n_axial)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise InputError(f"mesh {name} must be a positive integer, got {v!r}")
    n_nodes, n_tets = cylinder_counts(int(n_rings), int(n_axial))
    need = BYTES_FIXED + BYTES_PER_TET * n_tets
    have = available_memory_bytes() if available_bytes is None else available_bytes
    if need > have:
        raise InputError(
            f"mesh n_rings={n_rings}, n_axial={n_axial} ({n_nodes:,} nodes, {n_tets:,} tets) would need about "
            f"{format_bytes(need)} of memory; this machine has {format_bytes(have)} available. Use a coarser mesh."
        )
    return need


def cylinder_mesh(length_m: float, radius_m: float, n_rings: int, n_axial: int) -> TetMesh:
    """Structured tet mesh of a cylinder from x=0 to x=length along +x.

    ``n_rings`` rings across the radius and ``n_axial`` layers along the length give
    ``(1 + 3 n_rings (n_rings + 1)) (n_axial + 1)`` nodes and ``18 n_rings^2 n_axial`` tets.

    Parameters
    ----------
    length_m : float
        Length along +x, m.
    radius_m : float
        Radius, m.
    n_rings : int
        Rings across the radius (>= 1).
    n_axial : int
        Layers along the length (>= 1).

    Returns
    -------
    TetMesh
        The oriented mesh in frame W (the axis on +x, the base at x = 0).
    """
    check_mesh_size(n_rings, n_axial)  # before allocating anything
    xs = np.linspace(0.0, length_m, n_axial + 1)
    return layered_mesh(xs, np.full(len(xs), radius_m), n_rings)


def layered_mesh(xs: np.ndarray, radii_m: np.ndarray, n_rings: int) -> TetMesh:
    """Structured tet mesh of a solid of revolution along +x: one ring disk per layer.

    The layers of :func:`cylinder_mesh`, each disk with its own radius; the topology
    (node order, tets) depends only on ``n_rings`` and the number of layers.

    Parameters
    ----------
    xs : ndarray, shape (L,)
        The layers' positions along +x, increasing, m (L >= 2).
    radii_m : ndarray, shape (L,)
        The radius of each layer's disk, m.
    n_rings : int
        Rings across each disk (>= 1).

    Returns
    -------
    TetMesh
        The oriented mesh in frame W.
    """
    disks = {}
    for r in radii_m:
        if r not in disks:
            disks[r] = _disk(r, n_rings)
    disk, tris = disks[radii_m[0]]
    n_layer, n_axial = len(disk), len(xs) - 1
    X = np.concatenate([np.column_stack([np.full(n_layer, x), disks[r][0]]) for x, r in zip(xs, radii_m)])
    tris = np.sort(tris, axis=1)  # the prism split below relies on ascending node order
    tets = []
    for layer in range(n_axial):
        a, b, c = (tris + layer * n_layer).T
        a2, b2, c2 = a + n_layer, b + n_layer, c + n_layer
        tets += [np.column_stack(v) for v in ((a, b, c, a2), (b, c, a2, b2), (c, a2, b2, c2))]
    tets = np.concatenate(tets)
    return _oriented(TetMesh(X, tets))


def robot_mesh(robot, n_rings: int | None = None, n_axial: int | None = None) -> TetMesh:
    """The structured cylinder mesh of a robot description, at its own resolution unless
    ``n_rings``/``n_axial`` override it.

    Parameters
    ----------
    robot : RobotDescription
        Gives ``length_m``, ``radius_m`` (m) and the default ``n_rings``, ``n_axial``.
    n_rings, n_axial : int or None
        Overrides of the description's resolution.

    Returns
    -------
    TetMesh
        The :func:`cylinder_mesh` of the robot, in frame W.
    """
    n_rings = robot.n_rings if n_rings is None else n_rings
    n_axial = robot.n_axial if n_axial is None else n_axial
    return cylinder_mesh(robot.length_m, robot.radius_m, n_rings, n_axial)


def _oriented(mesh: TetMesh) -> TetMesh:
    vol = mesh.volumes()
    if np.any(np.abs(vol) < 1e-15 * np.max(np.abs(vol))):
        raise InputError("mesh has degenerate (zero-volume) tetrahedra")
    tets = mesh.tets.copy()
    flip = vol < 0
    tets[flip] = tets[flip][:, [0, 2, 1, 3]]
    return TetMesh(np.ascontiguousarray(mesh.X_W, dtype=float), tets.astype(np.int64))


def load_mesh(path) -> TetMesh:
    """Read a tetrahedral mesh (metres) with meshio: .msh, .vtu, .mesh, .xdmf, ...

    Only the tetrahedra and the nodes they use are kept; tets are reoriented positively.

    Parameters
    ----------
    path : str or os.PathLike
        The mesh file; its coordinates are read as m in frame W.

    Returns
    -------
    TetMesh
        The mesh (InputError if the file has no tetrahedra or a degenerate one).
    """
    import meshio

    m = meshio.read(path)
    tets = [c.data for c in m.cells if c.type == "tetra"]
    if not tets:
        raise InputError(f"{path}: no 'tetra' cells (only {[c.type for c in m.cells]})")
    used = np.unique(np.concatenate(tets))
    remap = np.full(len(m.points), -1)
    remap[used] = np.arange(len(used))
    return _oriented(TetMesh(np.asarray(m.points, float)[used, :3], remap[np.concatenate(tets)]))


def save_mesh(path, mesh: TetMesh) -> None:
    """Write a mesh's nodes (m) and tetrahedra with meshio, in the format of ``path``'s suffix.

    Parameters
    ----------
    path : str or os.PathLike
        The file to write (.msh, .vtu, ...).
    mesh : TetMesh
        The mesh.
    """
    import meshio

    meshio.write(path, meshio.Mesh(mesh.X_W, [("tetra", mesh.tets)]))


def barycentric(mesh: TetMesh, p_W: np.ndarray, tol: float = 1e-9) -> tuple[np.ndarray, np.ndarray]:
    """Embed points in the rest mesh: nodes (P, 4) and weights (P, 4) with
    ``p = sum_k weights[:, k] * X_W[nodes[:, k]]``. Points outside raise ValueError.

    Parameters
    ----------
    mesh : TetMesh
        The rest mesh.
    p_W : array_like, shape (P, 3) or (3,)
        Points in frame W, m.
    tol : float
        How far below zero a barycentric weight may be for a point on a face.

    Returns
    -------
    nodes : ndarray of int, shape (P, 4)
        The nodes of the tet holding each point.
    weights : ndarray, shape (P, 4)
        Barycentric weights, non-negative and summing to 1.
    """
    p_W = np.atleast_2d(np.asarray(p_W, dtype=float))
    X = mesh.X_W[mesh.tets]
    T = np.stack([X[:, 1] - X[:, 0], X[:, 2] - X[:, 0], X[:, 3] - X[:, 0]], axis=-1)
    T_inv = np.linalg.inv(T)
    nodes, weights = [], []
    for p in p_W:
        lam = np.einsum("mij,mj->mi", T_inv, p - X[:, 0])
        w = np.column_stack([1 - lam.sum(1), lam])
        best = np.argmax(w.min(axis=1))
        if w[best].min() < -tol:
            raise InputError(f"point {p.tolist()} m lies outside the mesh")
        nodes.append(mesh.tets[best])
        weights.append(np.clip(w[best], 0.0, None) / np.clip(w[best], 0.0, None).sum())
    return np.asarray(nodes), np.asarray(weights)
