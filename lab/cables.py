"""Cables as one-sided quadratic springs on the length of a polyline through via points.

A cable leaves its fixed anchor in the base plate and runs through eyelets embedded in
the body (barycentric weights of a tet), frictionless, so only its total length

    L(x) = |p_1 - anchor| + sum_k |p_{k+1} - p_k|,   p_k = sum_j w_kj x_{n_kj}

matters. Pulling motor angle ``u`` onto a spool of radius ``r`` shortens the free
length to ``L* = L0 + slack - r u``. The cable pulls only when stretched, d = L - L* > 0:

    E = k/2 max(d, 0)^2,  smoothed over 0 < d < eps (eps = ``slack_smoothing_m``)

The plain one-sided spring has a jump in stiffness at d = 0 that makes Newton
oscillate whenever a cable sits near taut (every cable at rest does); :func:`spring`
blends in a cubic so the energy is C2, with no tension at all while slack.
L is convex in x (a sum of norms of affine maps) and E is convex increasing in L, so
the cable Hessian is always positive semi-definite.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class CableRoute:
    """A cable embedded in a mesh: anchor (3,), via nodes (K, 4), weights (K, 4), rest
    length ``L0_m``, ``slack_m`` added to the free length (as-built defects)."""
    anchor_W: np.ndarray
    nodes: np.ndarray
    weights: np.ndarray
    L0_m: float
    slack_m: float = 0.0

    def points(self, x_W: np.ndarray) -> np.ndarray:
        """Polyline (K + 1, 3): anchor then via points, for node positions x_W (N, 3)."""
        p = np.einsum("kj,kjd->kd", self.weights, x_W[self.nodes])
        return np.vstack([self.anchor_W, p])

    def length(self, x_W: np.ndarray) -> float:
        return float(np.linalg.norm(np.diff(self.points(x_W), axis=0), axis=1).sum())

    def length_derivatives(self, x_W: np.ndarray):
        """L, dL/dp (K, 3) and d2L/dp2 (3K, 3K) with respect to the via points."""
        e = np.diff(self.points(x_W), axis=0)                 # segment s ends at via point s
        l = np.linalg.norm(e, axis=1)
        n = e / l[:, None]
        K = len(e)
        dL = n.copy()
        dL[:-1] -= n[1:]
        P = (np.eye(3)[None] - n[:, :, None] * n[:, None, :]) / l[:, None, None]
        H = np.zeros((K, 3, K, 3))
        for s in range(K):                                    # segment s joins via s-1 and via s
            H[s, :, s] += P[s]
            if s > 0:
                H[s - 1, :, s - 1] += P[s]
                H[s, :, s - 1] -= P[s]
                H[s - 1, :, s] -= P[s]
        return float(l.sum()), dL, H.reshape(3 * K, 3 * K)

    def embedding_matrix(self) -> np.ndarray:
        """W (3K, 12K): via point coordinates = W @ element dofs of ``self.nodes``."""
        K = len(self.nodes)
        W = np.zeros((K, 3, K, 4, 3))
        for k in range(K):
            for j in range(4):
                W[k, :, k, j, :] = self.weights[k, j] * np.eye(3)
        return W.reshape(3 * K, 12 * K)


def spring(d, k: float, eps: float):
    """One-sided spring on the stretch ``d`` (m): energy (J), tension dE/dd (N), d2E/dd2 (N/m).

    Exactly zero when slack (d <= 0), ``k/2 (d^2 - d eps + eps^2/3)`` beyond ``eps``, and
    the cubic ``k d^3 / (6 eps)`` in between, so E is C2 and Newton sees no kink."""
    d = np.asarray(d, dtype=float)
    dc = np.clip(d, 0.0, eps)                 # cubic part
    dq = np.maximum(d - eps, 0.0)             # quadratic part beyond eps
    energy = k * dc**3 / (6 * eps) + k * (0.5 * dq**2 + 0.5 * eps * dq)
    tension = k * dc**2 / (2 * eps) + k * dq
    stiffness = np.where(d >= eps, k, k * dc / eps)
    return energy, tension, stiffness
