"""Tension-controlled tendons: the description's cables, each pulled by a given tension.

The input of tendon c is its tension T_c (N), held constant whatever the body does (a motor
in torque mode, a hanging weight, a load cell in the loop). Frictionless through its via
points, the tendon does the work of that tension along its routed length L_c(x)
(:mod:`lab.fem.actuators.cable_routes`), so its energy is

    E = sum_c T_c (L_c(x) - L0_c)

(the rest length L0_c only fixes the zero at rest; pulling shortens the path). Its gradient is
A T with A = dL/dq (n_free, m), its Hessian sum_c T_c d2L_c/dq2 (exact, PSD: L is convex in
the via points), and d2E/dq dT_c = dL_c/dq. The law is linear in the inputs and smooth in q
(no spring, no slack), so the statics need no condensation. At the tension an angle-
controlled cable carries at an equilibrium, the tension-controlled tendon holds the same
equilibrium.
"""

from __future__ import annotations

import numpy as np

from lab.errors import InputError
from lab.fem.actuators.base import Actuator, register_actuator
from lab.fem.actuators.cable_routes import CableRoute, CableSet, embed_routes, route_block_dofs
from lab.fem.actuators.eyelet_shifts import eyelet_shift_force


@register_actuator("tendons_tension")
class TensionTendonActuator(Actuator):
    """The cables of a description as tendons, inputs their tensions (N, one per cable).

    Parameters
    ----------
    robot : RobotDescription
        Its cables (names and routes).
    routes : list of CableRoute
        Each tendon embedded in the body, with its rest length.
    free : FreeCoordinates
        The body's free coordinates.
    tension_max_n : array_like, shape (m,) or scalar
        The largest tension of each tendon, N (> 0).
    """

    input_unit = "N"

    def __init__(self, robot, routes: list[CableRoute], free, tension_max_n, cables=None):
        self.robot, self.routes, self.free = robot, routes, free
        self.cable_indices = tuple(range(len(robot.cables)) if cables is None else cables)
        self.input_names = tuple(f"tension_n[{robot.cables[i].name}]" for i in self.cable_indices)
        high = np.broadcast_to(np.asarray(tension_max_n, float), (len(routes),)).copy()
        if not np.all(np.isfinite(high)) or np.any(high <= 0):
            raise InputError(f"tendons_tension: tension_max_n {high.tolist()} N must be finite and > 0")
        self.tension_max_n = high
        self.set = CableSet(routes, free.dof_to_free, free.n_free)
        self.L0_m = np.array([r.L0_m for r in routes])

    @classmethod
    def build(cls, robot, body, free, *, tension_max_n=None, cables=None) -> TensionTendonActuator:
        """The description's cables, routed through their via points in ``body``, as tendons.

        Parameters
        ----------
        robot : RobotDescription
            The description.
        body : Body
            The body the via points are embedded in.
        free : FreeCoordinates
            Its free coordinates.
        tension_max_n : array_like, shape (m,) or scalar, optional
            The largest tension of each tendon, N; default each cable's ``tension_max_n``, or
            for an angle-controlled one ``cable_stiffness_n_m * spool_radius_m * u_max_rad``,
            the tension it reaches at full travel on a rigid body.
        cables : sequence of int, optional
            Which of the description's cables (indices); default all.

        Returns
        -------
        TensionTendonActuator
            The tendons, each with its rest length L0 at the rest mesh.
        """
        which = list(range(len(robot.cables)) if cables is None else cables)
        if tension_max_n is None:
            tension_max_n = [
                robot.cables[i].tension_max_n
                if robot.cables[i].tension_max_n is not None
                else robot.cable_stiffness_n_m * robot.spool_radius_m * robot.u_max_rad
                for i in which
            ]
        act = cls(robot, embed_routes(robot, body, None, which), free, tension_max_n, cables)
        act.mesh = body.mesh  # the eyelets' weight gradients (geometry_force_derivative)
        return act

    def input_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """[0, tension_max_n] N per tendon.

        Returns
        -------
        low, high : ndarray, shape (m,)
            Bounds in N.
        """
        return np.zeros(len(self.routes)), self.tension_max_n.copy()

    def lengths(self, x_W) -> np.ndarray:
        """The tendons' routed lengths.

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

    def energy(self, x_W, u) -> float:
        """The tensions' work along the routes, sum_c T_c (L_c - L0_c).

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (m,)
            Tensions, N.

        Returns
        -------
        float
            Energy, J.
        """
        return float(np.asarray(u, float) @ (self.lengths(x_W) - self.L0_m))

    def energy_and_gradient(self, x_W, u):
        """Energy and gradient A T, sharing the lengths.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (m,)
            Tensions, N.

        Returns
        -------
        energy : float
            J.
        g : ndarray, shape (n_free,)
            dE/dq, N.
        condensation : None
            No condensation.
        """
        u = np.asarray(u, float)
        L, A, _ = self.set.jacobian(x_W)
        return float(u @ (L - self.L0_m)), A @ u, None

    def gradient(self, x_W, u):
        """Gradient sum_c T_c dL_c/dq.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (m,)
            Tensions, N.

        Returns
        -------
        g : ndarray, shape (n_free,)
            dE/dq, N.
        condensation : None
            No condensation (the law is linear in T and smooth in q).
        """
        return self.set.jacobian(x_W)[1] @ np.asarray(u, float), None

    def block_dofs(self) -> list[np.ndarray]:
        """One dense block per tendon over the dofs of its via points' tets.

        Returns
        -------
        list of ndarray, shape (1, 12K)
            Mesh dofs (ravelled x, y, z per node) of each tendon's K via-point tets.
        """
        return route_block_dofs(self.routes)

    def hessian_blocks(self, x_W, u) -> list[np.ndarray]:
        """T_c W^T (d2L_c/dp2) W per tendon, ravelled.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (m,)
            Tensions, N.

        Returns
        -------
        list of ndarray, shape (144 K^2,)
            Each tendon's (12K, 12K) block over :meth:`block_dofs`, N/m.
        """
        blocks = []
        for c, t in zip(self.routes, np.asarray(u, float)):
            blocks.append((t * c.embed_hessian(c.length_derivatives(x_W)[2])).ravel())
        return blocks

    def hessian_product(self, x_W, u):
        """The taut tendons turning: T (d2L/dp2) dp, scattered to the free coordinates.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (m,)
            Tensions, N.

        Returns
        -------
        callable
            ``(acc, v, dx_W) -> acc + d2E/dq2 v`` for ``v`` (n_free,) m and the same
            displacement on the nodes ``dx_W`` (N, 3) m; ``acc`` (n_free,) N.
        """
        tendons = self.set
        segments = tendons.segments(x_W)
        t_via = np.asarray(u, float)[tendons.cable][:, None]

        def apply(acc, v, dx_W):
            turn = t_via * tendons.gradient_change(segments, tendons.via_points(dx_W))
            return acc + tendons.to_free(turn, False)

        return apply

    def mixed_derivative(self, x_W, u) -> np.ndarray:
        """How the tensions change the forces: d2E/dq dT_c = dL_c/dq.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (m,)
            Tensions, N.

        Returns
        -------
        ndarray, shape (n_free, m)
            d2E/dq dT, N/N (m per m).
        """
        return self.set.jacobian(x_W)[1]

    def input_states(self, x_W, u) -> tuple[bool, ...]:
        """Which tendons pull (T > 0).

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (m,)
            Tensions, N.

        Returns
        -------
        tuple of bool, length m
            True where the tendon's tension is positive.
        """
        return tuple(bool(t > 0) for t in np.asarray(u, float))

    def geometry_force_derivative(self, x_W, u, P: np.ndarray):
        """How the forces change with each tendon's eyelet shifts (as-built defects).

        :func:`~lab.fem.actuators.eyelet_shifts.eyelet_shift_force` of each tendon at its tension
        (no spring term, and no slack: a held tension takes it up).

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (m,)
            The tendons' tensions, N.
        P : ndarray, shape (3, a)
            The shift axes (columns of the identity).

        Returns
        -------
        d_slack : None
            Tendons held at a tension have no slack.
        d_shift : list of ndarray, shape (n_free, a)
            dg/d shift of each tendon's eyelets (all together), N/m.
        """
        out = [
            eyelet_shift_force(r, self.mesh, self.free, x_W, P, t)[0] for t, r in zip(np.asarray(u, float), self.routes)
        ]
        return None, out
