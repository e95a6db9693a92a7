"""The total energy E(x, u) of a cable-driven arm and its sparse derivatives.

    E(x, u) = sum_tets V psi(F)  -  sum_nodes m_a g . x_a  +  sum_cables k/2 s(L_c(x) - L*_c(u_c))^2

with the base face clamped (its nodes are removed from the unknowns) and psi the
neo-Hookean law, or another given as ``material`` (:mod:`lab.fem.hyperfoam`). The solver works
on ``q``, the stacked free coordinates; :meth:`ArmFEM.to_nodes` and
:meth:`ArmFEM.to_free` convert to and from node positions ``x_W`` (N, 3).

Sparse assembly uses a pattern computed once: every element and cable block's entries
are mapped to their slot in the CSR data array, so each Hessian is one ``bincount``.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from lab.description import RobotDescription
from lab.errors import InputError
from lab.fem.cables import CableRoute, CableSet, spring
from lab.fem.elasticity import NeoHookean, project_psd
from lab.fem.mesh import TetMesh, barycentric, robot_mesh


class ArmFEM:
    """FEM model of a robot description on a tet mesh.

    ``mesh``: defaults to the description's structured cylinder mesh;
    ``n_rings``/``n_axial`` override its resolution.
    ``youngs_modulus_pa``: optional per-tet modulus (M,) (e.g. an as-built stiffness
    gradient); ``cable_slack_m``: optional extra free length per cable (m,). Defaults:
    the description's (with its optional ``stiffness_gradient`` and cables' ``slack_m``).
    ``material``: another material law instead of the description's neo-Hookean one, an
    object whose ``on_mesh(mesh)`` gives the law on the mesh's elements, with the
    interface of :class:`NeoHookean` (e.g. :class:`lab.fem.hyperfoam.HyperfoamMaterial`,
    which holds its own per-tet modulus: then ``youngs_modulus_pa`` must be None).
    """

    def __init__(
        self,
        robot: RobotDescription,
        mesh: TetMesh | None = None,
        *,
        n_rings=None,
        n_axial=None,
        youngs_modulus_pa=None,
        cable_slack_m=None,
        clamp_tol_m: float = 1e-9,
        material=None,
    ):
        self.robot = robot
        self.mesh = robot_mesh(robot, n_rings, n_axial) if mesh is None else mesh
        mesh = self.mesh
        if material is not None:
            if youngs_modulus_pa is not None:
                raise InputError("give the modulus either as youngs_modulus_pa or in the material, not both")
            self.elastic = material.on_mesh(mesh)
        else:
            E = (
                robot.youngs_modulus_at(mesh.X_W[mesh.tets].mean(axis=1))
                if youngs_modulus_pa is None
                else youngs_modulus_pa
            )
            self.elastic = NeoHookean.from_mesh(mesh, E, robot.poisson_ratio)
        if np.any(self.elastic.V <= 0):
            raise InputError("mesh has tetrahedra with non-positive volume")

        # Lumped masses: a quarter of each tet's mass on each of its nodes.
        m_node = np.zeros(mesh.n_nodes)
        np.add.at(m_node, mesh.tets.ravel(), np.repeat(robot.density_kg_m3 * self.elastic.V / 4, 4))
        self.m_node_kg = m_node
        self.f_gravity_W = m_node[:, None] * robot.gravity_m_s2[None, :]

        clamped = mesh.X_W[:, 0] <= mesh.X_W[:, 0].min() + clamp_tol_m
        self.free_dofs = np.flatnonzero(np.repeat(~clamped, 3))
        self.n_free = len(self.free_dofs)

        slack = [c.slack_m for c in robot.cables] if cable_slack_m is None else np.asarray(cable_slack_m, float)
        self.cables = []
        for cable, s in zip(robot.cables, slack):
            nodes, weights = _embed(mesh, cable.via_points_m, f"cable '{cable.name}' via point")
            route = CableRoute(cable.anchor_m, nodes, weights, 0.0, float(s))
            self.cables.append(CableRoute(cable.anchor_m, nodes, weights, route.length(mesh.X_W), float(s)))
        self.tip_nodes, self.tip_weights = (a[0] for a in _embed(mesh, robot.p_tip_marker_W, "the tip marker"))
        self._build_pattern()
        dof_to_free = np.full(3 * mesh.n_nodes, -1)
        dof_to_free[self.free_dofs] = np.arange(self.n_free)
        self._cable_set = CableSet(self.cables, dof_to_free, self.n_free)
        self._S_tip = self._tip_matrix()

    # ---------------------------------------------------------------- coordinates
    @property
    def X_W(self) -> np.ndarray:
        return self.mesh.X_W

    def to_nodes(self, q: np.ndarray) -> np.ndarray:
        x = self.mesh.X_W.ravel().copy()
        x[self.free_dofs] = q
        return x.reshape(-1, 3)

    def to_free(self, x_W: np.ndarray) -> np.ndarray:
        return np.asarray(x_W).ravel()[self.free_dofs].copy()

    def rest_q(self) -> np.ndarray:
        return self.to_free(self.mesh.X_W)

    def tip(self, x_W: np.ndarray) -> np.ndarray:
        """Tip marker position p_tip_W (3,) in metres."""
        return self.tip_weights @ x_W[self.tip_nodes]

    def tip_matrix(self) -> sp.csr_matrix:
        """S (3, n_free) with p_tip = S q + const (the marker is embedded, so linear)."""
        return self._S_tip

    def _tip_matrix(self) -> sp.csr_matrix:
        rows, cols, vals = [], [], []
        dof_to_free = np.full(3 * self.mesh.n_nodes, -1)
        dof_to_free[self.free_dofs] = np.arange(self.n_free)
        for n, w in zip(self.tip_nodes, self.tip_weights):
            for d in range(3):
                if dof_to_free[3 * n + d] >= 0:
                    rows.append(d), cols.append(dof_to_free[3 * n + d]), vals.append(w)
        return sp.csr_matrix((vals, (rows, cols)), shape=(3, self.n_free))

    def cable_lengths(self, x_W) -> np.ndarray:
        """Length of each cable (m,) in m."""
        return self._cable_set.lengths(x_W)

    def cable_targets(self, u_motor) -> np.ndarray:
        """Free length L* = L0 + slack - r u of each cable (m,)."""
        return np.array([c.L0_m + c.slack_m for c in self.cables]) - self.robot.spool_radius_m * np.asarray(u_motor)

    def cable_tensions(self, x_W, u_motor) -> np.ndarray:
        """Tension of each cable in N (m,)."""
        d = self.cable_lengths(x_W) - self.cable_targets(u_motor)
        return self.cable_springs(d)[1]

    # ---------------------------------------------------------------- energy
    def energy(self, q: np.ndarray, u_motor, with_gradient: bool = False):
        """E(q, u) in J; +inf when an element is inverted. With ``with_gradient``, returns
        ``(E, g, d, A)``, also what :meth:`gradient` returns with ``with_cables`` (None
        when inverted), at the cost of about one gradient (the kinematics are shared)."""
        x = self.to_nodes(q)
        if with_gradient:
            e, g_nodes = self.elastic.energy_and_gradient(x)
        else:
            e = self.elastic.energy(x)
        if not np.isfinite(e):
            return (np.inf, None, None, None) if with_gradient else np.inf
        e -= float(np.sum(self.f_gravity_W * x))
        if with_gradient:
            L, A, _ = self._cable_set.jacobian(x)
        else:
            L = self.cable_lengths(x)
        d = L - self.cable_targets(u_motor)
        e_cables, tension, _ = self.cable_springs(d)
        e += float(np.sum(e_cables))
        return (e, self._assemble_gradient(g_nodes, A, tension), d, A) if with_gradient else e

    def gradient(self, q: np.ndarray, u_motor, with_cables: bool = False):
        """dE/dq (n_free,) in N. With ``with_cables``, returns ``(g, d, A)``: also the
        cable stretches d = L - L* (m,) in m and the length gradients A = dL/dq (n_free, m)."""
        x = self.to_nodes(q)
        L, A, _ = self._cable_set.jacobian(x)
        d = L - self.cable_targets(u_motor)
        g = self._assemble_gradient(self.elastic.nodal_gradient(x), A, self.cable_springs(d)[1])
        return (g, d, A) if with_cables else g

    def _assemble_gradient(self, g_nodes, A, tension):
        """dE/dq from the elastic nodal gradient (N, 3), gravity and cable tensions (m,) along A."""
        return (g_nodes - self.f_gravity_W).ravel()[self.free_dofs] + A @ tension

    def cable_springs(self, stretch_m):
        """Energy (J), tension (N) and stiffness (N/m) of each cable (m,) at stretches d = L - L* (m,)."""
        return spring(stretch_m, self.robot.cable_stiffness_n_m, self.robot.slack_smoothing_m)

    def hessian(self, q: np.ndarray, u_motor, project: bool = False) -> sp.csr_matrix:
        """d2E/dq2 (n_free, n_free), exact, or with each element block projected to PSD."""
        x = self.to_nodes(q)
        H_el = self.elastic.hessian(x)
        if project:
            H_el = project_psd(H_el)
        blocks = [H_el.ravel()]
        for c, L_star in zip(self.cables, self.cable_targets(u_motor)):
            L, dL_dp, d2L_dp2 = c.length_derivatives(x)
            _, dE, d2E = self.cable_springs(L - L_star)
            W = c.embedding_matrix()
            g_p = dL_dp.ravel()
            blocks.append((W.T @ (d2E * np.outer(g_p, g_p) + dE * d2L_dp2) @ W).ravel())
        values = np.concatenate(blocks)[self._keep]
        data = np.bincount(self._slot, weights=values, minlength=len(self._indices))
        return sp.csr_matrix((data, self._indices, self._indptr), shape=(self.n_free, self.n_free))

    def hessian_operator(self, q: np.ndarray, u_motor):
        """A function v (n_free,) -> d2E/dq2 v (n_free,) in N: exact Hessian products at
        ``q`` without assembling the Hessian (a setup and each product cost about as much
        as a gradient, ~0.4 ms on the default mesh, against ~6 ms for an assembly)."""
        x = self.to_nodes(q)
        elastic = self.elastic.hessian_product(x)
        cables = self._cable_set
        L, A, segments = cables.jacobian(x)
        _, tension, stiffness = self.cable_springs(L - self.cable_targets(u_motor))
        t_via = tension[cables.cable][:, None]

        def apply(v: np.ndarray) -> np.ndarray:
            dx = np.zeros(3 * self.mesh.n_nodes)
            dx[self.free_dofs] = v
            dx = dx.reshape(-1, 3)
            # Springs along dL/dq, plus the taut cables turning: tension (d2L/dp2) dp.
            turn = t_via * cables.gradient_change(segments, cables.via_points(dx))
            return elastic(dx).ravel()[self.free_dofs] + A @ (stiffness * (A.T @ v)) + cables.to_free(turn, False)

        return apply

    def mixed_derivative(self, q: np.ndarray, u_motor) -> np.ndarray:
        """d2E/dq du (n_free, m): how each motor angle changes the forces."""
        L, A, _ = self._cable_set.jacobian(self.to_nodes(q))
        stiffness = self.cable_springs(L - self.cable_targets(u_motor))[2]
        # d/du of dE/dL * dL/dq, with dd/du = +r (pulling shortens L*, stretching the cable)
        return A * (stiffness * self.robot.spool_radius_m)

    # ---------------------------------------------------------------- assembly pattern
    def _block_dofs(self) -> list[np.ndarray]:
        dofs = [(3 * self.mesh.tets[:, :, None] + np.arange(3)).reshape(-1, 12)]
        dofs += [(3 * c.nodes.ravel()[:, None] + np.arange(3)).reshape(1, -1) for c in self.cables]
        return dofs

    def _build_pattern(self) -> None:
        dof_to_free = np.full(3 * self.mesh.n_nodes, -1)
        dof_to_free[self.free_dofs] = np.arange(self.n_free)
        rows, cols = [], []
        for d in self._block_dofs():
            f = dof_to_free[d]
            rows.append(np.repeat(f, f.shape[1], axis=1).ravel())
            cols.append(np.tile(f, (1, f.shape[1])).ravel())
        rows, cols = np.concatenate(rows), np.concatenate(cols)
        self._keep = (rows >= 0) & (cols >= 0)
        key = rows[self._keep] * self.n_free + cols[self._keep]
        unique, self._slot = np.unique(key, return_inverse=True)
        r = unique // self.n_free
        self._indices = (unique % self.n_free).astype(np.int32)
        self._indptr = np.searchsorted(r, np.arange(self.n_free + 1)).astype(np.int32)


def _embed(mesh: TetMesh, points_W, what: str):
    """:func:`barycentric` weights of ``points_W`` (m), naming the point that is outside."""
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
                    f"{which}{np.round(p, 6).tolist()} m lies outside the mesh of the body (a faceted "
                    "cylinder, slightly inside the description's radius): move it inwards in the description"
                ) from None
        raise
