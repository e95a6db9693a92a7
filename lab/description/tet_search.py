"""Which tetrahedron of a mesh holds each of many points, and where in it (barycentric weights).

:func:`locate` checks each point against the tets whose centroids are nearest to it (a
k-d tree), and only the points none of those hold against every tet, so embedding a few
hundred points in a mesh of tens of thousands of tets takes milliseconds.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["locate"]


def _weights(X, tets, T_inv, idx, P):
    """Barycentric weights (P, k, 4) of points P (P, 3) in tets ``idx`` (P, k)."""
    lam = np.einsum("pkij,pkj->pki", T_inv[idx], P[:, None, :] - X[tets[idx, 0]])
    return np.concatenate([1 - lam.sum(-1, keepdims=True), lam], axis=-1)


def locate(X, tets, P, tol: float = 1e-9, k: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """The tet holding each point and its barycentric weights there.

    Among the tets holding a point (weights >= -tol; several for a point on a face, edge or
    node), the one whose smallest weight is largest is chosen.

    Parameters
    ----------
    X : ndarray, shape (N, 3)
        Node positions, m.
    tets : ndarray of int, shape (M, 4)
        Tetrahedra (either orientation).
    P : array_like, shape (P, 3) or (3,)
        The points, m.
    tol : float
        How far below zero a weight may be for a point on a face.
    k : int
        Tets checked first per point (those with the nearest centroids).

    Returns
    -------
    tet : ndarray of int, shape (P,)
        The index of the holding tet, -1 for a point outside the mesh.
    weights : ndarray, shape (P, 4)
        Barycentric weights in that tet (summing to 1), those of the nearest-looking tet
        for a point outside.
    """
    X = np.asarray(X, float)
    tets = np.asarray(tets)
    P = np.atleast_2d(np.asarray(P, float))
    V = X[tets]
    T_inv = np.linalg.inv(np.stack([V[:, 1] - V[:, 0], V[:, 2] - V[:, 0], V[:, 3] - V[:, 0]], axis=-1))
    k = min(k, len(tets))
    _, near = cKDTree(V.mean(axis=1)).query(P, k=k)
    near = np.asarray(near).reshape(len(P), k)
    w = _weights(X, tets, T_inv, near, P)
    best = np.argmax(w.min(axis=-1), axis=1)
    rows = np.arange(len(P))
    tet, weights = near[rows, best], w[rows, best]
    missed = np.flatnonzero(weights.min(axis=1) < -tol)
    everything = np.arange(len(tets))
    for i in missed:  # near no centroid: try every tet
        wi = _weights(X, tets, T_inv, everything[None, :], P[i : i + 1])[0]
        j = int(np.argmax(wi.min(axis=1)))
        tet[i], weights[i] = j, wi[j]
    tet = np.where(weights.min(axis=1) < -tol, -1, tet)
    return tet, weights
