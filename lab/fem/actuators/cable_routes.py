"""Cables as one-sided quadratic springs on the length of a polyline through via points.

A cable runs from its fixed anchor in the base plate through eyelets embedded in the body
(barycentric weights of a tet), frictionless, so only its length (m) matters:

    L(x) = |p_1 - anchor| + sum_k |p_{k+1} - p_k|,   p_k = sum_j w_kj x_{n_kj}

Motor angle ``u`` (rad) on a spool of radius ``r`` sets the free length
``L* = L0 + slack - r u``; the cable pulls only when stretched, d = L - L* > 0:
``E = k/2 max(d, 0)^2``, which :func:`spring` smooths with a cubic over 0 < d < eps
(``slack_smoothing_m``) so the energy is C2 and Newton does not oscillate near taut (a
plain one-sided spring jumps in stiffness at d = 0), with no tension while slack.
L is convex in x and E convex increasing in L, so the cable Hessian is always PSD.

A cable that stretches itself (stiffness ``k_c``, an as-built defect) is a second spring in
series: its free length grows by T / k_c, so at a stretch d the tension is T = k_eff d with
``k_eff = k k_c / (k + k_c)`` (:func:`series_stiffness`) and the energy of the pair,
T^2 / 2k + T^2 / 2k_c, is k_eff d^2 / 2: the same one-sided spring with ``k_eff`` (exact
beyond the smoothing width; the smoothing, a numerical device, is kept as it is).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class CableRoute:
    """A cable embedded in a mesh: its anchor and K via points (eyelets) in tets.

    Attributes
    ----------
    anchor_W : ndarray, shape (3,)
        The fixed anchor in frame W, m.
    nodes : ndarray of int, shape (K, 4)
        The nodes of each via point's tet.
    weights : ndarray, shape (K, 4)
        The via points' barycentric weights.
    L0_m : float
        Rest length, m.
    slack_m : float
        Added to the free length (as-built defects), m.
    """

    anchor_W: np.ndarray
    nodes: np.ndarray
    weights: np.ndarray
    L0_m: float
    slack_m: float = 0.0

    def points(self, x_W: np.ndarray) -> np.ndarray:
        """The cable's polyline: anchor then via points.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions in frame W, m.

        Returns
        -------
        ndarray, shape (K + 1, 3)
            Its points in frame W, m.
        """
        p = np.einsum("kj,kjd->kd", self.weights, x_W[self.nodes])
        return np.vstack([self.anchor_W, p])

    def length(self, x_W: np.ndarray) -> float:
        """The cable's length L.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions in frame W, m.

        Returns
        -------
        float
            L, m.
        """
        return float(np.linalg.norm(np.diff(self.points(x_W), axis=0), axis=1).sum())

    def length_gradient(self, x_W: np.ndarray):
        """The length and its gradient with respect to the via points.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions in frame W, m.

        Returns
        -------
        L : float
            Length, m.
        dL_dp : ndarray, shape (K, 3)
            dL/dp per via point, m per m.
        """
        L, dL, _, _ = self._segments(x_W)
        return L, dL

    def _segments(self, x_W):
        e = np.diff(self.points(x_W), axis=0)  # segment s ends at via point s
        l = np.linalg.norm(e, axis=1)
        n = e / l[:, None]
        dL = n.copy()
        dL[:-1] -= n[1:]
        return float(l.sum()), dL, n, l

    def length_derivatives(self, x_W: np.ndarray):
        """The length and its first two derivatives with respect to the via points.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions in frame W, m.

        Returns
        -------
        L : float
            Length, m.
        dL_dp : ndarray, shape (K, 3)
            dL/dp per via point, m per m.
        d2L_dp2 : ndarray, shape (3K, 3K)
            d2L/dp2, 1/m, via point coordinates ravelled x, y, z per point.
        """
        L, dL, n, l = self._segments(x_W)
        K = len(l)
        P = (np.eye(3)[None] - n[:, :, None] * n[:, None, :]) / l[:, None, None]
        H = np.zeros((K, 3, K, 3))
        s, t = np.arange(K), np.arange(1, K)  # segment s joins via s-1 and via s
        H[s, :, s] += P
        H[t - 1, :, t - 1] += P[1:]
        H[t, :, t - 1] -= P[1:]
        H[t - 1, :, t] -= P[1:]
        return L, dL, H.reshape(3 * K, 3 * K)

    def embed_hessian(self, H_p: np.ndarray) -> np.ndarray:
        """``W^T H_p W`` (:meth:`embedding_matrix`) without forming W: a second derivative
        with respect to the via points as one over the dofs of their tets.

        Parameters
        ----------
        H_p : ndarray, shape (3K, 3K)
            With respect to the via point coordinates (ravelled x, y, z per point).

        Returns
        -------
        ndarray, shape (12K, 12K)
            With respect to the dofs of ``self.nodes`` (ravelled x, y, z per node).
        """
        K = len(self.nodes)
        w = self.weights
        H = (w[:, :, None, None, None, None] * H_p.reshape(K, 1, 3, K, 1, 3)) * w[None, None, None, :, :, None]
        return H.reshape(12 * K, 12 * K)

    def embedding_matrix(self) -> np.ndarray:
        """The via points as a linear map of the dofs of their tets.

        Returns
        -------
        ndarray, shape (3K, 12K)
            W with via point coordinates = W @ element dofs of ``self.nodes`` (ravelled
            x, y, z per node), m per m.
        """
        K = len(self.nodes)
        W = np.zeros((K, 3, K, 4, 3))
        for k in range(K):
            for j in range(4):
                W[k, :, k, j, :] = self.weights[k, j] * np.eye(3)
        return W.reshape(3 * K, 12 * K)


def embed_routes(robot, body, slack_m=None, cables=None) -> list[CableRoute]:
    """The description's cables embedded in ``body``, each with its rest length.

    Parameters
    ----------
    robot : RobotDescription
        Its cables' anchors and via points (frame W, m).
    body : Body
        The body the via points are embedded in (an error names a via point no tet holds).
    slack_m : array_like, shape (m,), optional
        Extra free length per cable, m; default 0 for each.
    cables : sequence of int, optional
        Which of the description's cables (indices); default all.

    Returns
    -------
    list of CableRoute
        One route per cable, L0 measured on the rest mesh.
    """
    chosen = [robot.cables[i] for i in (range(len(robot.cables)) if cables is None else cables)]
    slack = np.zeros(len(chosen)) if slack_m is None else slack_m
    routes = []
    for cable, s in zip(chosen, slack):
        nodes, weights = body.embed(cable.via_points_m, f"cable '{cable.name}' via point")
        route = CableRoute(cable.anchor_m, nodes, weights, 0.0, float(s))
        routes.append(CableRoute(cable.anchor_m, nodes, weights, route.length(body.mesh.X_W), float(s)))
    return routes


def route_block_dofs(routes: list[CableRoute]) -> list[np.ndarray]:
    """One dense Hessian block per route over the dofs of its via points' tets.

    Parameters
    ----------
    routes : list of CableRoute
        The routes.

    Returns
    -------
    list of ndarray, shape (1, 12K)
        Mesh dofs (ravelled x, y, z per node) of each route's K via-point tets.
    """
    return [(3 * c.nodes.ravel()[:, None] + np.arange(3)).reshape(1, -1) for c in routes]


def spring(d, k: float, eps: float):
    """One-sided spring on the stretch ``d`` (m): energy (J), tension dE/dd (N), d2E/dd2 (N/m).

    Exactly zero when slack (d <= 0), ``k/2 (d^2 - d eps + eps^2/3)`` beyond ``eps``, and
    the cubic ``k d^3 / (6 eps)`` in between, so E is C2 and Newton sees no kink.

    Parameters
    ----------
    d : array_like
        Stretches L - L*, m (any shape).
    k : float
        Stiffness when taut, N/m.
    eps : float
        Smoothing width, m.

    Returns
    -------
    energy, tension, stiffness : ndarray
        In J, N and N/m, each shaped as ``d``.
    """
    d = np.asarray(d, dtype=float)
    dc = np.minimum(np.maximum(0.0, d), eps)  # cubic part: np.clip(d, 0, eps), without its overhead
    dq = np.maximum(d - eps, 0.0)  # quadratic part beyond eps
    energy = k * dc**3 / (6 * eps) + k * (0.5 * dq**2 + 0.5 * eps * dq)
    tension = k * dc**2 / (2 * eps) + k * dq
    stiffness = np.where(d >= eps, k, k * dc / eps)
    return energy, tension, stiffness


def series_stiffness(k_spring: float, k_cable) -> np.ndarray:
    """Stiffness (N/m) of the cable spring ``k_spring`` (N/m) in series with the cable's own
    ``k_cable`` (N/m, scalar or (m,); ``inf``: inextensible, giving ``k_spring`` exactly):
    ``1 / (1/k_spring + 1/k_cable)``."""
    k_cable = np.asarray(k_cable, dtype=float)
    with np.errstate(invalid="ignore"):
        k_eff = k_spring * k_cable / (k_spring + k_cable)
    return np.where(np.isinf(k_cable), float(k_spring), k_eff)


def route_hessian(route: CableRoute, x_W: np.ndarray, L_star_m: float, k: float, eps: float) -> np.ndarray:
    """d2E/dx2 (12K, 12K) of one cable's spring (stiffness ``k`` N/m, smoothing ``eps`` m) at
    free length ``L_star_m`` over the dofs of ``route.nodes`` (K, 4), ravelled x, y, z per
    node: ``W^T (E'' g g^T + E' d2L/dp2) W`` with g = dL/dp."""
    L, dL_dp, d2L_dp2 = route.length_derivatives(x_W)
    _, tension, stiffness = spring(L - L_star_m, k, eps)
    g = dL_dp.ravel()
    return route.embed_hessian(stiffness * np.outer(g, g) + tension * d2L_dp2)


class CableSet:
    """All cables of a mesh at once: their via points stacked (V in all), so lengths,
    dL/dq and the change of dL/dp take a few array operations instead of a Python loop
    per cable (the solver needs them with every energy and gradient).

    ``dof_to_free`` maps the mesh's dofs (3N,) to free coordinates (-1 where clamped)."""

    def __init__(self, routes: list[CableRoute], dof_to_free: np.ndarray, n_free: int):
        sizes = np.array([len(r.nodes) for r in routes])
        self.m, self.n_free = len(routes), n_free
        self.nodes = np.concatenate([r.nodes for r in routes])  # (V, 4)
        self.weights = np.concatenate([r.weights for r in routes])  # (V, 4)
        self.cable = np.repeat(np.arange(self.m), sizes)  # cable of each via point
        V = len(self.nodes)
        first = np.cumsum(sizes) - sizes
        # Segment v runs from prev[v] to via point v; rows V.. of the stacked points are
        # the anchors (and row V + m a zero row, the "next" of each cable's last point).
        self.prev = np.arange(V) - 1
        self.prev[first] = V + np.arange(self.m)
        self.next = np.arange(V) + 1
        self.next[first + sizes - 1] = V + self.m
        self.anchors = np.array([r.anchor_W for r in routes]).reshape(-1, 3)
        free = dof_to_free[3 * self.nodes[:, :, None] + np.arange(3)]  # (V, 4, 3)
        self._keep = (free >= 0).ravel()
        self._rows = (np.repeat(self.cable, 12) * n_free + free.ravel())[self._keep]

    def via_points(self, x_W: np.ndarray) -> np.ndarray:
        """Via point positions (V, 3) for node positions ``x_W`` (N, 3)."""
        return np.einsum("vj,vjd->vd", self.weights, x_W[self.nodes])

    def segments(self, x_W: np.ndarray):
        """Unit directions n (V, 3) and lengths l (V,) of the segments ending at each via point."""
        p = self.via_points(x_W)
        e = p - np.vstack([p, self.anchors])[self.prev]
        l = np.linalg.norm(e, axis=1)
        return e / l[:, None], l

    def lengths(self, x_W: np.ndarray) -> np.ndarray:
        """Cable lengths L (m,) in m."""
        return np.bincount(self.cable, weights=self.segments(x_W)[1], minlength=self.m)

    def to_free(self, f_via: np.ndarray, per_cable: bool) -> np.ndarray:
        """Via-point vectors (V, 3) (e.g. dL/dp) to free coordinates: summed into (n_free,),
        or kept apart per cable as (n_free, m) if ``per_cable``."""
        w = (self.weights[:, :, None] * f_via[:, None, :]).ravel()[self._keep]
        if per_cable:
            return np.bincount(self._rows, weights=w, minlength=self.m * self.n_free).reshape(self.m, -1).T
        return np.bincount(self._rows % self.n_free, weights=w, minlength=self.n_free)

    def jacobian(self, x_W: np.ndarray):
        """Cable lengths L (m,) in m and their gradients dL/dq (n_free, m), with the
        segment directions and lengths (see :meth:`segments`)."""
        n, l = self.segments(x_W)
        dL = n - np.vstack([n, np.zeros((self.m + 1, 3))])[self.next]
        return np.bincount(self.cable, weights=l, minlength=self.m), self.to_free(dL, True), (n, l)

    def gradient_change(self, segments, dp: np.ndarray) -> np.ndarray:
        """(d2L/dp2) dp (V, 3) for via point displacements dp (V, 3), at the segments
        (n, l) of :meth:`segments`: dn = (I - n n^T) de / l per segment."""
        n, l = segments
        de = dp - np.vstack([dp, np.zeros((self.m, 3))])[self.prev]  # the anchors do not move
        dn = (de - n * np.einsum("vi,vi->v", n, de)[:, None]) / l[:, None]
        return dn - np.vstack([dn, np.zeros((self.m + 1, 3))])[self.next]
