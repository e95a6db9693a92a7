"""Body points a rig observes: embedded in a tet, or on a stalk outside the body.

A point inside the rest mesh is embedded with barycentric weights (:func:`embed_points`,
the tet holding it). A point outside it -- a marker on a stalk or a ring -- moves with the
material around the body point X_a nearest to it (on the mesh's surface): with the
least-squares affine fit x(X) ~ c + F (X - X_a) of the node positions over the nodes
nearest X_a (at least 16, more until they span three dimensions), the marker is
p = c + F (P - X_a). c and F are linear in the node positions, so p is too: the marker is a
:class:`~lab.fem.bodies.base.Marker` with more than four nodes and weights summing to 1,
some negative.

This is exact whenever the neighbourhood moves affinely, rigid motions included. Under a
strain varying across the neighbourhood (bending) the fitted F is the neighbourhood's mean
deformation gradient, and the stalk stretches and bends with it: the error is about the
strain's variation times the stalk's length (a stiff stalk would stay straight). A point
farther from the body than half its length is refused: no stalk is that long, a unit or
frame mistake is likelier.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from lab.errors import InputError
from lab.fem.bodies.base import Marker
from lab.fem.bodies.mesh import TetMesh, barycentric

__all__ = ["STALK_REACH", "body_markers", "closest_surface_point", "embed_points", "marker_at", "stalk_marker"]

#: The farthest a stalk marker may be from the body, as a fraction of the body's length (x extent).
STALK_REACH = 0.5
#: Nodes the affine fit of a stalk's base starts with.
_FIT_NODES = 16


def embed_points(mesh: TetMesh, points_W, what: str, hint: str) -> tuple[np.ndarray, np.ndarray]:
    """:func:`~lab.fem.bodies.mesh.barycentric` embedding of points, naming the one outside.

    Parameters
    ----------
    mesh : TetMesh
        The rest mesh.
    points_W : array_like, shape (P, 3) or (3,)
        Points in frame W, m.
    what : str
        What the points are (e.g. ``"cable 'top' via point"``).
    hint : str
        What the mesh is, for the error (e.g. ``"a faceted cylinder, ..."``).

    Returns
    -------
    nodes, weights : ndarray, shape (P, 4)
        Each point's tet nodes and barycentric weights (InputError for a point outside).
    """
    points_W = np.atleast_2d(points_W)
    try:
        return barycentric(mesh, points_W)
    except InputError:
        for i, p in enumerate(points_W):
            try:
                barycentric(mesh, p)
            except InputError:
                which = f"{what} {i} " if len(points_W) > 1 else f"{what} "
                raise InputError(
                    f"{which}{np.round(p, 6).tolist()} m lies outside the mesh of the body ({hint}): move it "
                    "inwards in the description"
                ) from None
        raise


def closest_surface_point(mesh: TetMesh, p) -> tuple[np.ndarray, float]:
    """The point of the mesh's boundary nearest to ``p``.

    Parameters
    ----------
    mesh : TetMesh
        The rest mesh.
    p : array_like, shape (3,)
        A point, m.

    Returns
    -------
    X_a : ndarray, shape (3,)
        The nearest boundary point, m.
    distance : float
        Its distance from ``p``, m.
    """
    p = np.asarray(p, float)
    T = mesh.X_W[mesh.surface_triangles()]
    A, B, C = T[:, 0], T[:, 1], T[:, 2]
    ab, ac, ap, bp, cp = B - A, C - A, p - A, p - B, p - C
    d1, d2 = np.einsum("fi,fi->f", ab, ap), np.einsum("fi,fi->f", ac, ap)
    d3, d4 = np.einsum("fi,fi->f", ab, bp), np.einsum("fi,fi->f", ac, bp)
    d5, d6 = np.einsum("fi,fi->f", ab, cp), np.einsum("fi,fi->f", ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):  # Ericson's regions; the masked ones are finite
        s = 1.0 / (va + vb + vc)
        q = A + ab * (vb * s)[:, None] + ac * (vc * s)[:, None]  # inside the face
        regions = [
            ((va <= 0) & (d4 >= d3) & (d5 >= d6), B + (C - B) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)))[:, None]),
            ((vb <= 0) & (d2 >= 0) & (d6 <= 0), A + ac * (d2 / (d2 - d6))[:, None]),
            ((d6 >= 0) & (d5 <= d6), C),
            ((vc <= 0) & (d1 >= 0) & (d3 <= 0), A + ab * (d1 / (d1 - d3))[:, None]),
            ((d3 >= 0) & (d4 <= d3), B),
            ((d1 <= 0) & (d2 <= 0), A),
        ]
        for mask, point in regions:  # later regions take precedence, as in Ericson's order
            q[mask] = point[mask]
    d = np.linalg.norm(q - p, axis=1)
    j = int(np.argmin(d))
    return q[j], float(d[j])


def stalk_marker(mesh: TetMesh, p, field: str, reach_m: float) -> Marker:
    """A point outside the body moving with the material frame of the nearest body point.

    Parameters
    ----------
    mesh : TetMesh
        The rest mesh.
    p : array_like, shape (3,)
        The point at rest, m.
    field : str
        The description field giving it, for the error.
    reach_m : float
        The farthest it may be from the body, m.

    Returns
    -------
    Marker
        Nodes (K,) and weights (K,) summing to 1 (InputError if ``p`` is beyond ``reach_m``).
    """
    p = np.asarray(p, float)
    X_a, dist = closest_surface_point(mesh, p)
    if dist > reach_m:
        raise InputError(
            f"field '{field}' {np.round(p, 6).tolist()} m lies {dist:.4g} m outside the body, farther than a "
            f"stalk reaches ({STALK_REACH} x the body's length = {reach_m:.4g} m): is it in metres, frame W?"
        )
    X = mesh.X_W
    tree = cKDTree(X)
    k = min(_FIT_NODES, len(X))
    while True:
        _, nodes = tree.query(X_a, k=k)
        D = X[nodes] - X_a
        sv = np.linalg.svd(D - D.mean(axis=0), compute_uv=False)
        if sv[-1] > 0.2 * sv[0] or k == len(X):
            break
        k = min(2 * k, len(X))
    A = np.column_stack([np.ones(k), D])  # x_j ~ c + F (X_j - X_a), rows j
    weights = np.linalg.pinv(A).T @ np.concatenate([[1.0], p - X_a])
    return Marker(np.asarray(nodes, np.int64), weights)


def marker_at(body, p, field: str) -> Marker:
    """A body point: embedded if a tet holds it (:meth:`Body.embed`), else on a stalk.

    Parameters
    ----------
    body : Body
        The body.
    p : array_like, shape (3,)
        The point at rest, frame W, m.
    field : str
        The description field giving it (e.g. ``"markers[0].position_m"``).

    Returns
    -------
    Marker
        Its nodes and weights.
    """
    try:
        nodes, weights = body.embed(p, field)
        return Marker(nodes[0], weights[0])
    except InputError:
        X = body.mesh.X_W
        return stalk_marker(body.mesh, p, field, STALK_REACH * float(X[:, 0].max() - X[:, 0].min()))


def body_markers(body, robot) -> dict[str, Marker]:
    """The observed points of a description on a body: the tip marker, then ``robot.markers``.

    Parameters
    ----------
    body : Body
        The body.
    robot : RobotDescription
        Its ``p_tip_marker_W`` (3,) and ``markers`` (names, positions (3,) m).

    Returns
    -------
    dict of str to Marker
        ``{"tip": ..., NAME: ...}`` in the description's order.
    """
    out = {"tip": marker_at(body, robot.p_tip_marker_W, "tip_marker.position_m")}
    for i, m in enumerate(getattr(robot, "markers", ())):
        out[m.name] = marker_at(body, m.position_m, f"markers[{i}].position_m")
    return out
