"""The assembled model: body + material + gravity + actuators, its energy E(q, u) and derivatives.

    E(q, u) = sum_tets V psi(F)  -  sum_nodes m_a g . x_a  +  sum_actuators E_a(x, u_a)

on a body (:mod:`lab.fem.bodies`, default the description's clamped cylinder) with a
material law psi (:mod:`lab.fem.materials`, default the description's neo-Hookean) and
actuators (:mod:`lab.fem.actuators`, default its angle-controlled cables), each owning a
slice u_a of the inputs u. The solver works on ``q``, the stacked free coordinates;
:meth:`ArmFEM.to_nodes` and :meth:`ArmFEM.to_free` convert to and from node positions
``x_W`` (N, 3).

Sparse assembly uses a pattern computed once (:class:`lab.fem.assembly.HessianPattern`):
every element and actuator block's entries are mapped to their slot in the CSR data array.
The element sums (energy, gradient, Hessians added straight into those slots) run as
compiled kernels (:mod:`lab.fem.kernels`), or, as the reference, the law's NumPy methods
with one ``bincount``.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from lab.description import RobotDescription
from lab.errors import InputError
from lab.fem.assembly import HessianPattern
from lab.fem.bodies import CylinderBody, FreeCoordinates, body_of
from lab.fem.bodies.mesh import TetMesh
from lab.fem.kernels import assembly_backend, compiled_law
from lab.fem.materials.neo_hookean import project_psd
from lab.fem.model_inputs import ActuatedModel
from lab.fem.model_markers import ObservedModel
from lab.fem.model_material import description_material


class ArmFEM(ActuatedModel, ObservedModel):
    """FEM model of a robot description: a body, a material, gravity and actuators.

    Parameters
    ----------
    robot : RobotDescription
        The description (geometry, material, cables, gravity).
    mesh : TetMesh, optional
        A mesh clamped at its base instead of the description's body (:func:`lab.fem.bodies.body_of`:
        its cylinder, tapered solid or mesh file).
    n_rings, n_axial : int, optional
        Override the description's mesh resolution.
    youngs_modulus_pa : ndarray, shape (M,), optional
        Per-tet modulus (e.g. an as-built stiffness gradient), Pa; default the
        description's (with its optional ``stiffness_gradient``).
    cable_slack_m : array_like, shape (m,), optional
        Extra free length per cable, m; default the cables' ``slack_m``.
    clamp_tol_m : float, optional
        Nodes within this distance of the base plane of ``mesh`` are clamped, m (default 1e-9).
    material : Material, optional
        Another law (:class:`lab.fem.materials.Material`, e.g.
        :class:`~lab.fem.materials.HyperfoamMaterial`, which holds its own per-tet
        modulus: then ``youngs_modulus_pa`` must be None).
    body : Body, optional
        Another body (:mod:`lab.fem.bodies`) instead of the description's cylinder (then
        ``mesh``, ``n_rings``, ``n_axial`` and ``clamp_tol_m`` must not be given).
    actuators : list, optional
        Names in :data:`lab.fem.actuators.ACTUATORS`, or ``(name, options)`` pairs, built
        in order, each owning the next inputs of u; default the description's cables, each
        by its control (:func:`lab.fem.model_inputs.description_actuators`; ``["cables"]`` when
        all are angle-controlled).
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
        clamp_tol_m: float | None = None,
        material=None,
        body=None,
        actuators=None,
    ):
        self.robot = robot
        if body is None and mesh is None and clamp_tol_m is None:
            body = body_of(robot, n_rings=n_rings, n_axial=n_axial)  # the description's body
        elif body is None:  # a given mesh (or base tolerance): clamped at its base, markers embedded
            tol = 1e-9 if clamp_tol_m is None else clamp_tol_m
            body = CylinderBody(robot, mesh, n_rings=n_rings, n_axial=n_axial, clamp_tol_m=tol)
        elif mesh is not None or n_rings is not None or n_axial is not None:
            raise InputError("give the mesh either in the body or as mesh/n_rings/n_axial, not both")
        self.body = body
        self.mesh = mesh = body.mesh
        if material is not None:
            if youngs_modulus_pa is not None:
                raise InputError("give the modulus either as youngs_modulus_pa or in the material, not both")
        else:
            E = (
                robot.youngs_modulus_at(mesh.X_W[mesh.tets].mean(axis=1))
                if youngs_modulus_pa is None
                else youngs_modulus_pa
            )
            material = description_material(robot, E)
        self.elastic = material.on_mesh(mesh)
        if np.any(self.elastic.V <= 0):
            raise InputError("mesh has tetrahedra with non-positive volume")

        # Lumped masses: a quarter of each tet's mass on each of its nodes.
        m_node = np.zeros(mesh.n_nodes)
        np.add.at(m_node, mesh.tets.ravel(), np.repeat(robot.density_kg_m3 * self.elastic.V / 4, 4))
        self.m_node_kg = m_node
        self.f_gravity_W = m_node[:, None] * robot.gravity_m_s2[None, :]

        self.coordinates = FreeCoordinates.of(body)
        self.free_dofs = self.coordinates.free_dofs
        self.n_free = self.coordinates.n_free
        self.actuators = self._build_actuators(actuators, cable_slack_m)
        self.markers = body.markers()
        self.tip_nodes, self.tip_weights = self.markers["tip"].nodes, self.markers["tip"].weights
        dofs = [(3 * mesh.tets[:, :, None] + np.arange(3)).reshape(-1, 12)]  # the tets', then the actuators'
        dofs += [d for act in self.actuators for d in act.block_dofs()]
        self._pattern = HessianPattern.of(dofs, self.coordinates.dof_to_free, self.n_free)
        self._compiled = (None, None)  # (law, its compiled sums), see _sums
        self._S_tip = self.coordinates.point_matrix(self.markers["tip"])
        self._S_markers = sp.vstack([self.coordinates.point_matrix(m) for m in self.markers.values()]).tocsr()

    # ---------------------------------------------------------------- coordinates
    @property
    def X_W(self) -> np.ndarray:
        """Rest node positions (N, 3), m."""
        return self.mesh.X_W

    def to_nodes(self, q: np.ndarray) -> np.ndarray:
        """Node positions of free coordinates (the clamped nodes at rest).

        Parameters
        ----------
        q : ndarray, shape (n_free,)
            Free coordinates, m.

        Returns
        -------
        ndarray, shape (N, 3)
            Node positions x_W, m.
        """
        x = self.mesh.X_W.ravel().copy()
        x[self.free_dofs] = q
        return x.reshape(-1, 3)

    def to_free(self, x_W: np.ndarray) -> np.ndarray:
        """Free coordinates of node positions.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.

        Returns
        -------
        ndarray, shape (n_free,)
            Free coordinates q, m.
        """
        return np.asarray(x_W).ravel()[self.free_dofs].copy()

    def rest_q(self) -> np.ndarray:
        """Free coordinates at rest.

        Returns
        -------
        ndarray, shape (n_free,)
            q at the rest mesh, m.
        """
        return self.to_free(self.mesh.X_W)

    # ---------------------------------------------------------------- energy
    def energy(self, q: np.ndarray, u, with_gradient: bool = False, with_hessian: bool = False):
        """The total energy.

        Parameters
        ----------
        q : ndarray, shape (n_free,)
            Free coordinates, m.
        u : array_like, shape (n_inputs,)
            Inputs of all actuators.
        with_gradient : bool
            Also the gradient, at the cost of about one gradient (shared kinematics).
        with_hessian : bool
            Also the gradient and the exact Hessian at ``u`` (:meth:`hessian`), with the
            compiled kernels in the same pass over the tets: what a Newton step needs at a
            trial point it expects to accept.

        Returns
        -------
        float or tuple
            E in J (+inf when an element is inverted); with ``with_gradient``,
            ``(E, g, condensation)`` as :meth:`gradient` with ``with_condensation``
            (``(inf, None, None)`` when inverted); with ``with_hessian``
            ``(E, g, condensation, H)`` (``(inf, None, None, None)``).
        """
        x, law = self.to_nodes(q), self._sums()
        if with_hessian and not self._hessian_in_one_pass(law):  # a pass for each
            e, g, c = self.energy(q, u, with_gradient=True)
            return (e, g, c, self.hessian(q, u)) if np.isfinite(e) else (np.inf, None, None, None)
        if with_hessian:
            data = np.zeros(self._pattern.nnz)
            e, g_nodes = law.energy_gradient_hessian(x, data, self._pattern.element_slots)
        elif with_gradient:
            e, g_nodes = law.energy_and_gradient(x)
        else:
            e = law.energy(x)
        if not np.isfinite(e):
            if with_hessian:
                return np.inf, None, None, None
            return (np.inf, None, None) if with_gradient else np.inf
        e -= float(np.sum(self.f_gravity_W * x))
        if not (with_gradient or with_hessian):
            for act, u_a in self._split(u):
                e += act.energy(x, u_a)
            return e
        g, condensation = (g_nodes - self.f_gravity_W).ravel()[self.free_dofs], None
        for act, u_a in self._split(u):
            e_a, g_a, c = act.energy_and_gradient(x, u_a)
            e, g, condensation = e + e_a, g + g_a, self._offset(act, c) or condensation
        if not with_hessian:
            return e, g, condensation
        return e, g, condensation, self._with_blocks(law, x, u, data)

    @property
    def trial_hessians_pay(self) -> bool:
        """Whether a Newton solver's line search should assemble the next step's Hessian with
        a trial's energy (:meth:`energy` ``with_hessian``; ``lab.fem.solve.statics.FUSED_TRIALS``):
        where the law's evaluation is costly beside its Hessian (the hyperfoam kernels). With
        the neo-Hookean's, the Hessians of the trials rejected (one in four) cost more than
        the evaluations the others save."""
        law = self._sums()
        return self._hessian_in_one_pass(law) and bool(getattr(law, "costly_energy", False))

    def _hessian_in_one_pass(self, law) -> bool:
        """Whether :meth:`energy` ``with_hessian`` is one pass of ``law`` (this model's sums):
        the compiled kernels, and :meth:`hessian` not overridden by a subclass."""
        return law is not self.elastic and type(self).hessian is ArmFEM.hessian

    def gradient(self, q: np.ndarray, u, with_condensation: bool = False):
        """dE/dq.

        Parameters
        ----------
        q : ndarray, shape (n_free,)
            Free coordinates, m.
        u : array_like, shape (n_inputs,)
            Inputs of all actuators.
        with_condensation : bool
            Also the actuators' :class:`~lab.fem.actuators.Condensation` (or None).

        Returns
        -------
        ndarray, shape (n_free,), or tuple
            The gradient in N, or ``(g, condensation)``.
        """
        x = self.to_nodes(q)
        g, condensation = (self._sums().nodal_gradient(x) - self.f_gravity_W).ravel()[self.free_dofs], None
        for act, u_a in self._split(u):
            g_a, c = act.gradient(x, u_a)
            g, condensation = g + g_a, self._offset(act, c) or condensation
        return (g, condensation) if with_condensation else g

    @staticmethod
    def _offset(act, condensation):
        """The condensation with its input slice moved to the actuator's place in u."""
        if condensation is not None:
            s = condensation.inputs
            if isinstance(act.inputs, slice):
                condensation.inputs = slice(act.inputs.start + s.start, act.inputs.start + s.stop)
            else:  # the actuator's inputs are scattered among u (cables of mixed control)
                condensation.inputs = act.inputs[s]
        return condensation

    def hessian(self, q: np.ndarray, u, project: bool = False) -> sp.csr_matrix:
        """d2E/dq2 (n_free, n_free) in N/m, exact, or with each element block projected to PSD.

        A volume chamber's rank-one fluid stiffness (``Condensation.in_hessian=False``) is left
        out: the statics add it by Woodbury; :meth:`hessian_operator` includes it.

        Parameters
        ----------
        q : ndarray, shape (n_free,)
            Free coordinates, m.
        u : array_like, shape (n_inputs,)
            Inputs.
        project : bool
            Project each element's block of the elastic Hessian to PSD.

        Returns
        -------
        scipy.sparse.csr_matrix, shape (n_free, n_free)
            The Hessian.
        """
        x = self.to_nodes(q)
        law, pattern = self._sums(), self._pattern
        blocks = [b for act, u_a in self._split(u) for b in act.hessian_blocks(x, u_a)]
        if law is self.elastic:  # the NumPy reference: all blocks summed by one bincount
            H_el = law.hessian(x)
            return self._corrected(pattern.assemble([(project_psd(H_el) if project else H_el).ravel(), *blocks]), x, u)
        data = np.zeros(pattern.nnz)
        if project:
            law.scatter(data, pattern.element_slots.ravel(), project_psd(law.hessian(x)).ravel())
        else:
            law.add_hessian(x, data, pattern.element_slots)
        return self._with_blocks(law, x, u, data, blocks)

    def _with_blocks(self, law, x, u, data, blocks=None) -> sp.csr_matrix:
        """The Hessian from the CSR ``data`` of its elements, the actuators' blocks added."""
        if blocks is None:
            blocks = [b for act, u_a in self._split(u) for b in act.hessian_blocks(x, u_a)]
        for block, slots in zip(blocks, self._pattern.block_slots, strict=True):
            law.scatter(data, slots, block)
        return self._corrected(self._pattern.matrix(data), x, u)

    def _corrected(self, H: sp.csr_matrix, x: np.ndarray, u) -> sp.csr_matrix:
        """The assembled Hessian ``H`` with what a subclass adds in place (none here)."""
        return H

    def hessian_operator(self, q: np.ndarray, u):
        """Exact Hessian products at ``q`` without assembling the Hessian (a setup and each
        product cost about as much as a gradient; docs/fem-cost.md has both costs).

        Parameters
        ----------
        q : ndarray, shape (n_free,)
            Free coordinates, m.
        u : array_like, shape (n_inputs,)
            Inputs.

        Returns
        -------
        callable
            v (n_free,) m -> d2E/dq2 v (n_free,) N.
        """
        x = self.to_nodes(q)
        elastic = self._sums().hessian_product(x)
        products = [act.hessian_product(x, u_a) for act, u_a in self._split(u)]

        def apply(v: np.ndarray) -> np.ndarray:
            dx = np.zeros(3 * self.mesh.n_nodes)
            dx[self.free_dofs] = v
            dx = dx.reshape(-1, 3)
            acc = elastic(dx).ravel()[self.free_dofs]
            for product in products:
                acc = product(acc, v, dx)
            return acc

        return apply

    def volume_ratio(self, q: np.ndarray) -> np.ndarray:
        """det F of every tet: its volume over its rest volume (the compiled kernels' when in use).

        Parameters
        ----------
        q : ndarray, shape (n_free,)
            Free coordinates, m.

        Returns
        -------
        ndarray, shape (M,)
            The ratios (negative where a tet is inverted).
        """
        return self._sums().volume_ratio(self.to_nodes(q))

    # ---------------------------------------------------------------- assembly
    def _sums(self):
        """The elastic law's element sums: its compiled kernels when they are in use
        (:mod:`lab.fem.kernels`; built at the first call), else the law itself."""
        if assembly_backend(len(self.elastic.V)) != "compiled":
            return self.elastic
        if self._compiled[0] is not self.elastic:
            self._compiled = (self.elastic, compiled_law(self.elastic))
        return self._compiled[1] or self.elastic
