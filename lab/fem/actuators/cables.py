"""Angle-controlled cables: the description's cables, each pulled in by a motor on a spool.

Motor angle u_c (rad) on a spool of radius r sets cable c's free length
L*_c = L0_c + slack_c - r u_c; the cable is a one-sided spring on its stretch
d_c = L_c(x) - L*_c (:mod:`lab.fem.actuators.cable_routes`), so its energy is
sum_c E_spring(d_c), its gradient A tau with A = dL/dq (n_free, m), and d2E/dq du = r A K
(dd/du = +r: pulling shortens L*, stretching the cable). The springs' law is stiff and
kinked near taut, so the statics keep it exact along the m stretches
(:class:`~lab.fem.actuators.base.Condensation`).
"""

from __future__ import annotations

import numpy as np

from lab.errors import InputError
from lab.fem.actuators.base import Actuator, Condensation, register_actuator
from lab.fem.actuators.cable_routes import CableRoute, CableSet, embed_routes, route_block_dofs, spring
from lab.fem.actuators.eyelet_shifts import eyelet_shift_force


@register_actuator("cables")
class CableActuator(Actuator):
    """The cables of a description, inputs the motor angles (rad, one per cable).

    Parameters
    ----------
    robot : RobotDescription
        Its cables, ``spool_radius_m``, ``u_max_rad``, safety rules, spring stiffness and
        smoothing.
    routes : list of CableRoute
        Each cable embedded in the body.
    free : FreeCoordinates
        The body's free coordinates.
    mesh : TetMesh
        The body's rest mesh (for the eyelets' weight gradients).
    law : callable, optional
        Stretch (m,) m -> (energy J, tension N, stiffness N/m), each (m,); default the
        description's one-sided spring (:func:`spring`).
    """

    input_unit = "rad"
    condenses = True

    def __init__(self, robot, routes: list[CableRoute], free, mesh, law=None, cables=None):
        self.robot, self.routes, self.free, self.mesh = robot, routes, free, mesh
        self.cable_indices = tuple(range(len(robot.cables)) if cables is None else cables)
        self.input_names = tuple(f"u_motor[{robot.cables[i].name}]" for i in self.cable_indices)
        self.law = self.springs if law is None else law
        self.set = CableSet(routes, free.dof_to_free, free.n_free)

    @classmethod
    def build(cls, robot, body, free, *, slack_m=None, law=None, cables=None) -> CableActuator:
        """The description's cables embedded in ``body``.

        Parameters
        ----------
        robot : RobotDescription
            The description.
        body : Body
            The body the eyelets are embedded in.
        free : FreeCoordinates
            Its free coordinates.
        slack_m : array_like, shape (m,), optional
            Extra free length per cable, m; default the cables' ``slack_m``.
        law : callable, optional
            The springs' law (see the class).
        cables : sequence of int, optional
            Which of the description's cables (indices; default all, the motor angles in order).

        Returns
        -------
        CableActuator
            The cables, each with its rest length L0 at the rest mesh.
        """
        which = range(len(robot.cables)) if cables is None else cables
        slack = [robot.cables[i].slack_m for i in which] if slack_m is None else np.asarray(slack_m, float)
        return cls(robot, embed_routes(robot, body, slack, which), free, body.mesh, law, cables)

    def springs(self, stretch_m):
        """The description's one-sided springs.

        Parameters
        ----------
        stretch_m : array_like, shape (m,) or scalar
            Stretches d = L - L*, m.

        Returns
        -------
        energy, tension, stiffness : ndarray
            In J, N and N/m, shaped as ``stretch_m``.
        """
        return spring(stretch_m, self.robot.cable_stiffness_n_m, self.robot.slack_smoothing_m)

    def input_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """[0, u_max] rad per motor (the safety rules are checked by :meth:`check_input`).

        Returns
        -------
        low, high : ndarray, shape (m,)
            Bounds in rad.
        """
        m = len(self.routes)
        return np.zeros(m), np.full(m, self.robot.u_max_rad)

    def check_input(self, u) -> np.ndarray:
        """The description's check of motor angles (range and safety rules).

        Parameters
        ----------
        u : array_like, shape (m,)
            Motor angles, rad.

        Returns
        -------
        ndarray, shape (m,)
            The angles as floats (InputError if refused).
        """
        if len(self.cable_indices) == len(self.robot.cables):
            return self.robot.check_command(u)
        u = np.asarray(u, dtype=float)  # some of the cables: the model checks the safety rules on all inputs
        if u.shape != (len(self.routes),) or not np.all(np.isfinite(u)):
            raise InputError(f"expected {len(self.routes)} finite motor angles, got {u.tolist()}")
        if np.any(u < -1e-9) or np.any(u > self.robot.u_max_rad * (1 + 1e-9)):
            raise InputError(f"motor angles {u.tolist()} rad outside [0, {self.robot.u_max_rad}]")
        return u

    def targets(self, u) -> np.ndarray:
        """The cables' free lengths L* = L0 + slack - r u.

        Parameters
        ----------
        u : array_like, shape (m,)
            Motor angles, rad.

        Returns
        -------
        ndarray, shape (m,)
            L*, m.
        """
        return np.array([c.L0_m + c.slack_m for c in self.routes]) - self.robot.spool_radius_m * np.asarray(u)

    def lengths(self, x_W) -> np.ndarray:
        """The cables' lengths.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.

        Returns
        -------
        ndarray, shape (m,)
            Lengths L, m.
        """
        return self.set.lengths(x_W)

    def tensions(self, x_W, u) -> np.ndarray:
        """The cables' tensions.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (m,)
            Motor angles, rad.

        Returns
        -------
        ndarray, shape (m,)
            Tensions, N (0 where slack).
        """
        return self.law(self.lengths(x_W) - self.targets(u))[1]

    def energy(self, x_W, u) -> float:
        """The springs' energy (see :meth:`Actuator.energy`).

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (m,)
            Motor angles, rad.

        Returns
        -------
        float
            Energy, J.
        """
        return float(np.sum(self.law(self.lengths(x_W) - self.targets(u))[0]))

    def energy_and_gradient(self, x_W, u):
        """Energy, gradient A tau and the stretches' :class:`Condensation`, sharing the lengths.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (m,)
            Motor angles, rad.

        Returns
        -------
        energy : float
            J.
        g : ndarray, shape (n_free,)
            dE/dq, N.
        condensation : Condensation
            The m stretches.
        """
        L, A, _ = self.set.jacobian(x_W)
        d = L - self.targets(u)
        values = self.law(d)
        return float(np.sum(values[0])), A @ values[1], self._condensation(A, d, values)

    def gradient(self, x_W, u):
        """Gradient A tau and the stretches' :class:`Condensation`.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (m,)
            Motor angles, rad.

        Returns
        -------
        g : ndarray, shape (n_free,)
            dE/dq, N.
        condensation : Condensation
            The m stretches.
        """
        L, A, _ = self.set.jacobian(x_W)
        d = L - self.targets(u)
        values = self.law(d)
        return A @ values[1], self._condensation(A, d, values)

    def _condensation(self, A, stretch, values) -> Condensation:
        inputs, robot = slice(0, len(self.routes)), self.robot
        return Condensation(A, stretch, self.law, robot.slack_smoothing_m, inputs, robot.spool_radius_m, values=values)

    def block_dofs(self) -> list[np.ndarray]:
        """One dense block per cable over the dofs of its eyelets' tets.

        Returns
        -------
        list of ndarray, shape (1, 12K)
            Mesh dofs (ravelled x, y, z per node) of each cable's K eyelet tets.
        """
        return route_block_dofs(self.routes)

    def hessian_blocks(self, x_W, u) -> list[np.ndarray]:
        """W^T (E'' g g^T + E' d2L/dp2) W per cable, g = dL/dp, ravelled.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (m,)
            Motor angles, rad.

        Returns
        -------
        list of ndarray, shape (144 K^2,)
            Each cable's (12K, 12K) block over :meth:`block_dofs`, N/m.
        """
        blocks = []
        for c, L_star in zip(self.routes, self.targets(u)):
            L, dL_dp, d2L_dp2 = c.length_derivatives(x_W)
            _, dE, d2E = self.law(L - L_star)
            g_p = dL_dp.ravel()
            blocks.append(c.embed_hessian(d2E * np.outer(g_p, g_p) + dE * d2L_dp2).ravel())
        return blocks

    def hessian_product(self, x_W, u):
        """Springs along dL/dq, plus the taut cables turning: tension (d2L/dp2) dp.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (m,)
            Motor angles, rad.

        Returns
        -------
        callable
            ``(acc, v, dx_W) -> acc + d2E/dq2 v`` for ``v`` (n_free,) m and the same
            displacement on the nodes ``dx_W`` (N, 3) m; ``acc`` (n_free,) N.
        """
        cables = self.set
        L, A, segments = cables.jacobian(x_W)
        _, tension, stiffness = self.law(L - self.targets(u))
        t_via = tension[cables.cable][:, None]

        def apply(acc, v, dx_W):
            turn = t_via * cables.gradient_change(segments, cables.via_points(dx_W))
            return acc + A @ (stiffness * (A.T @ v)) + cables.to_free(turn, False)

        return apply

    def mixed_derivative(self, x_W, u) -> np.ndarray:
        """How the motor angles change the forces: d2E/dq du = r A K.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (m,)
            Motor angles, rad.

        Returns
        -------
        ndarray, shape (n_free, m)
            d2E/dq du, N/rad.
        """
        L, A, _ = self.set.jacobian(x_W)
        stiffness = self.law(L - self.targets(u))[2]
        return A * (stiffness * self.robot.spool_radius_m)

    def input_states(self, x_W, u) -> tuple[bool, ...]:
        """Which cables pull (tension > 0).

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (m,)
            Motor angles, rad.

        Returns
        -------
        tuple of bool, length m
            True where the cable is taut.
        """
        return tuple(bool(t > 0) for t in self.tensions(x_W, u))

    def geometry_force_derivative(self, x_W, u, P: np.ndarray):
        """How the forces change with each cable's slack and eyelet shifts (as-built defects).

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (m,)
            Motor angles, rad.
        P : ndarray, shape (3, a)
            The shift axes (columns of the identity).

        Returns
        -------
        d_slack : ndarray, shape (n_free, m)
            dg/d slack_c in N/m.
        d_shift : list of ndarray, shape (n_free, a)
            dg/d shift_c of each cable's eyelets (all together), N/m.
        """
        L, A, _ = self.set.jacobian(x_W)
        stretch = L - self.targets(u)
        _, tension, stiffness = self.law(stretch)
        d_shift = []
        for c, route in enumerate(self.routes):
            col, dL, dp = eyelet_shift_force(route, self.mesh, self.free, x_W, P, tension[c])
            _, dL0 = route.length_gradient(self.mesh.X_W)
            dd = np.einsum("ki,kia->a", dL, dp) - dL0.sum(axis=0) @ P
            d_shift.append(col + stiffness[c] * np.outer(A[:, c], dd))
        return -A * stiffness, d_shift
