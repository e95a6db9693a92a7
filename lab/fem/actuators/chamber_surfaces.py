"""The cavities of a tet mesh as closed, oriented triangle surfaces, and their volumes.

A cavity's wall is made of boundary faces of the mesh, each belonging to exactly one tet.
Every face here is wound so that its normal points away from its tet, i.e. INTO the cavity:
the winding :meth:`lab.fem.bodies.mesh.TetMesh.surface_triangles` gives every boundary face.
With it the divergence theorem gives the volume a closed surface encloses as
V = -sum det[x1, x2, x3] / 6 (exact, independent of the origin). :func:`cavity_surfaces`
finds a mesh's cavities; :func:`oriented_surface` checks and orients a given one.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from lab.errors import InputError

__all__ = ["cavity_surfaces", "cavity_volume", "oriented_surface"]


def _signed(x_W: np.ndarray, tri: np.ndarray) -> float:
    """sum det[x1, x2, x3] / 6 over the triangles, m^3."""
    a, b, c = x_W[tri[:, 0]], x_W[tri[:, 1]], x_W[tri[:, 2]]
    return float(np.einsum("ij,ij->", a, np.cross(b, c)) / 6.0)


def cavity_volume(x_W: np.ndarray, surface: np.ndarray) -> float:
    """The volume a closed surface wound with normals into the cavity encloses.

    Parameters
    ----------
    x_W : ndarray, shape (N, 3)
        Node positions, m.
    surface : ndarray of int, shape (T, 3)
        The cavity's triangles, normals pointing into the cavity.

    Returns
    -------
    float
        The volume V = -sum det[x1, x2, x3] / 6, m^3.
    """
    return -_signed(np.asarray(x_W, float), np.asarray(surface))


def cavity_surfaces(mesh) -> list[np.ndarray]:
    """The cavities of a tet mesh: its boundary split into connected pieces, less the outer one.

    The outer boundary is the piece enclosing the largest volume; every other piece is a
    cavity.

    Parameters
    ----------
    mesh : TetMesh
        The body's mesh.

    Returns
    -------
    list of ndarray of int, shape (T_c, 3)
        Each cavity's triangles, wound with normals into the cavity (away from their tet),
        as :class:`PressureChamberActuator` expects; ordered by their lowest node index.
    """
    faces = mesh.surface_triangles()
    n = mesh.n_nodes
    rows = np.repeat(np.arange(len(faces)), 3)
    graph = coo_matrix((np.ones(rows.size), (n + rows, faces.ravel())), shape=(n + len(faces),) * 2)
    _, label = connected_components(graph, directed=False)
    label = label[n:]  # faces sharing a node lie in one piece
    pieces = [faces[label == k] for k in np.unique(label)]
    enclosed = [abs(_signed(mesh.X_W, p)) for p in pieces]
    outer = int(np.argmax(enclosed))
    cavities = [p for k, p in enumerate(pieces) if k != outer]
    return sorted(cavities, key=lambda p: int(p.min()))


def oriented_surface(mesh, surface, name: str) -> np.ndarray:
    """A cavity's triangles as boundary faces of ``mesh``, each wound away from its tet.

    Parameters
    ----------
    mesh : TetMesh
        The body's mesh.
    surface : array_like of int, shape (T, 3)
        The cavity's triangles (node indices), in any winding.
    name : str
        The chamber's name, for the errors.

    Returns
    -------
    ndarray of int, shape (T, 3)
        The triangles, normals into the cavity (InputError if one is not a boundary face
        of the mesh or the surface is not closed).
    """
    surface = np.asarray(surface)
    if surface.ndim != 2 or surface.shape[1] != 3 or len(surface) < 4:
        raise InputError(f"chamber {name!r}: surface must be (T, 3) node indices with T >= 4, got {surface.shape}")
    faces = mesh.surface_triangles()
    index = {tuple(k): i for i, k in enumerate(np.sort(faces, axis=1).tolist())}
    found = [index.get(tuple(k), -1) for k in np.sort(surface, axis=1).tolist()]
    if min(found) < 0:
        bad = surface[found.index(-1)].tolist()
        raise InputError(f"chamber {name!r}: triangle {bad} is not a boundary face of the body's mesh")
    tri = faces[found]
    # Closed: every edge in exactly two triangles, once each way.
    edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    fwd = np.unique(edges, axis=0, return_counts=True)
    rev = np.unique(edges[:, ::-1], axis=0)
    if np.any(fwd[1] != 1) or len(fwd[0]) != len(rev) or np.any(fwd[0] != rev):
        raise InputError(f"chamber {name!r}: its surface is not closed (an edge not shared by two triangles)")
    return tri
