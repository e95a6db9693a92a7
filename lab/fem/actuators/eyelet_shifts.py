"""How a tendon's force changes as its eyelets shift (the as-built eyelet parameters).

An eyelet p_k = sum_j w_kj(p0_k + delta) x_j sits in a tet with barycentric weights w; a
shift delta of its rest position moves it with the local deformation and changes the
weights (:func:`weight_gradients`). A tendon at tension T pulls with T dL/dq, which turns
and moves with the shift (:func:`eyelet_shift_force`). The angle cables add their spring's
change of stretch; the tension tendons use it as it is.
"""

from __future__ import annotations

import numpy as np


def eyelet_shift_force(route, mesh, free, x_W: np.ndarray, P: np.ndarray, tension_n: float):
    """How a tendon's force at a held tension changes as its eyelets shift.

    The force T dL/dq, with via points p_k = sum_j w_kj(p0_k + delta) x_j, changes by
    T d(dL/dq)/d delta: the path turning and the weights moving. Shared by the angle
    cables (plus their spring term) and the tension tendons.

    Parameters
    ----------
    route : CableRoute
        The tendon.
    mesh : TetMesh
        The rest mesh (the eyelets' weight gradients), m.
    free : FreeCoordinates
        The body's free coordinates.
    x_W : ndarray, shape (N, 3)
        Node positions, m.
    P : ndarray, shape (3, a)
        The shift axes (columns of the identity).
    tension_n : float
        The tension T, N.

    Returns
    -------
    col : ndarray, shape (n_free, a)
        dg/d shift, N/m.
    dL : ndarray, shape (K, 3)
        dL/d p_k at ``x_W``.
    dp : ndarray, shape (K, 3, a)
        How the via points move with the shift.
    """
    grad_w = weight_gradients(mesh, route.nodes)
    F = np.einsum("kji,kjd->kid", x_W[route.nodes], grad_w)
    dp = F @ P  # (K, 3, a)
    _, dL, HL = route.length_derivatives(x_W)
    K = len(route.nodes)
    blk = route.embedding_matrix().T @ (HL @ dp.reshape(3 * K, -1))  # (12K, a)
    blk += np.einsum("ki,kja->kjia", dL, grad_w @ P).reshape(12 * K, -1)
    dofs = free.dof_to_free[(3 * route.nodes.ravel()[:, None] + np.arange(3)).ravel()]
    col = np.zeros((free.n_free, P.shape[1]))
    np.add.at(col, dofs[dofs >= 0], tension_n * blk[dofs >= 0])
    return col, dL, dp


def weight_gradients(mesh, nodes: np.ndarray) -> np.ndarray:
    """d w / d p (K, 4, 3): gradients of the barycentric weights of points in the tets with
    ``nodes`` (K, 4) (constant in each tet: w = T^-1 [1; p], T = [1 1 1 1; X^T])."""
    T = np.concatenate([np.ones((len(nodes), 1, 4)), mesh.X_W[nodes].transpose(0, 2, 1)], axis=1)
    return np.linalg.inv(T)[:, :, 1:]
