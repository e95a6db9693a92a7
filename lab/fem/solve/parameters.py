"""The as-built arm as a parametrised FEM: parameters theta -> :class:`ArmFEM`, and dx/dtheta.

The same defects as the emulated as-built robot (``lab.asbuilt.arm``), as one vector
theta (p,) = ``[ln s, g_y, g_z, delta_1, ..., delta_m, sigma_1, ..., sigma_m]``: log softness
``ln s`` (s = E_as-built / E), stiffness gradient ``g`` across the section (dimensionless,
|g| < 1), eyelet shift ``delta_c`` of cable c (m; (y, z) by default, (x, y, z) with
``axes="xyz"``) and slack ``sigma_c`` (m, added to the free length: L* = L0 + sigma_c - r u).
The nominal theta (:attr:`ParametrisedFEM.nominal`) gives exactly the FEM of ``ArmFEM(robot)``.

Sensitivities: at an equilibrium dE/dq = 0, so dq/dtheta = -H^-1 dg/dtheta and
J_tip_theta = S dq/dtheta, with the exact Hessian H factorised once for dq/du and dq/dtheta
together (as :func:`lab.fem.solve.statics.sensitivities`) and the mixed derivative dg/dtheta analytic.

Each parameter, why (y, z) shifts by default (measured), and the derivatives: docs/design/fem.md.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from lab.description import RobotDescription
from lab.errors import InputError
from lab.fem.bodies.mesh import TetMesh, robot_mesh
from lab.fem.model import ArmFEM
from lab.fem.solve.linsolve import factorize
from lab.fem.solve.parameter_layout import AXES, ParameterError, ParameterLayout
from lab.fem.solve.statics import StaticSolution, solve_static


class ParametrisedFEM:
    """The FEM of ``robot`` as a function of theta (module docstring), on one fixed mesh
    (``mesh``, else ``n_rings``/``n_axial``, else the description's resolution).

    Parameters
    ----------
    robot : RobotDescription
        The nominal robot; its theta is :attr:`nominal`.
    n_rings, n_axial : int, optional
        Mesh resolution overrides.
    mesh : TetMesh, optional
        The rest mesh in frame W (m); default the description's cylinder.
    axes : str
        The eyelet shifts' axes, ``"yz"`` or ``"xyz"`` (see :class:`ParameterLayout`).
    """

    def __init__(
        self, robot: RobotDescription, *, n_rings=None, n_axial=None, mesh: TetMesh | None = None, axes: str = "yz"
    ):
        self.robot = robot
        self.mesh = robot_mesh(robot, n_rings, n_axial) if mesh is None else mesh
        mesh = self.mesh
        self.layout = ParameterLayout(tuple(c.name for c in robot.cables), axes)
        self._centroids_W = mesh.X_W[mesh.tets].mean(axis=1)
        self._section = self._centroids_W[:, 1:] / robot.radius_m  # c_t / R (M, 2)
        self.nominal = self.layout.pack(
            gradient=robot.stiffness_gradient[1:], slack_m=[c.slack_m for c in robot.cables]
        )
        self._cached: tuple[bytes, ArmFEM] | None = None

    def check(self, theta) -> dict:
        """:meth:`ParameterLayout.unpack`, refusing non-finite values or ``|g| >= 1``.

        Parameters
        ----------
        theta : array_like, shape (p,)
            The parameters (module docstring).

        Returns
        -------
        dict
            As :meth:`ParameterLayout.unpack` (ParameterError if refused).
        """
        theta = np.asarray(theta, float)
        if not np.all(np.isfinite(theta)):
            raise ParameterError(f"parameters must be finite, got {theta.tolist()}")
        v = self.layout.unpack(theta)
        if np.hypot(*v["gradient"]) >= 1:
            raise ParameterError(f"stiffness gradient |g| must be < 1, got {v['gradient'].tolist()}")
        return v

    def youngs_modulus(self, theta) -> np.ndarray:
        """Per-tet Young's modulus, s E (1 + g . c_t / R) at tet centroid c_t.

        Parameters
        ----------
        theta : array_like, shape (p,)
            The parameters (module docstring).

        Returns
        -------
        ndarray, shape (M,)
            E_t, Pa.
        """
        v = self.check(theta)
        g = np.array([0.0, *v["gradient"]])
        return (self.robot.youngs_modulus_pa * v["softness"]) * (1.0 + self._centroids_W @ g / self.robot.radius_m)

    def description(self, theta) -> RobotDescription:
        """The robot description of the arm at theta (see :func:`as_built_description`).

        Parameters
        ----------
        theta : array_like, shape (p,)
            The parameters (module docstring).

        Returns
        -------
        RobotDescription
            The as-built description.
        """
        self.check(theta)
        return as_built_description(self.robot, self.layout, theta)

    def fem(self, theta) -> ArmFEM:
        """The :class:`ArmFEM` at theta (the last one is cached). Raises
        :class:`ParameterError` for an eyelet shifted out of the mesh.

        Parameters
        ----------
        theta : array_like, shape (p,)
            The parameters (module docstring).

        Returns
        -------
        ArmFEM
            The assembled model on this object's mesh.
        """
        theta = np.asarray(theta, float)
        key = theta.tobytes()
        if self._cached is None or self._cached[0] != key:
            robot = self.description(theta)
            for c in robot.cables:
                x = c.via_points_m[:, 0]
                if np.any(np.diff(x) <= 0) or np.any(x <= 0) or np.any(x > robot.length_m):
                    raise ParameterError(f"eyelets of cable {c.name!r} shifted out of order or off the body's length")
            try:
                fem = ArmFEM(
                    robot,
                    self.mesh,
                    youngs_modulus_pa=self.youngs_modulus(theta),
                    cable_slack_m=robot_slack(robot),
                )
            except InputError as err:
                raise ParameterError(f"parameters outside the body: {err}") from None
            self._cached = (key, fem)
        return self._cached[1]

    def solve(self, theta, u_motor, q0=None, **kwargs) -> StaticSolution:
        """:func:`lab.fem.solve.statics.solve_static` of the FEM at theta.

        Parameters
        ----------
        theta : array_like, shape (p,)
            The parameters.
        u_motor : array_like, shape (m,)
            Motor angles, rad.
        q0 : ndarray, shape (n_free,), optional
            Start, m; default rest.
        **kwargs
            More options of ``solve_static``.

        Returns
        -------
        StaticSolution
            The equilibrium.
        """
        return solve_static(self.fem(theta), u_motor, q0, **kwargs)

    def force_derivative(self, theta, q: np.ndarray, u_motor) -> np.ndarray:
        """How the forces change with theta.

        The material part scales each tet's elastic force; the cables' slack and eyelet
        shifts come from :meth:`lab.fem.actuators.CableActuator.geometry_force_derivative`.

        Parameters
        ----------
        theta : array_like, shape (p,)
            The parameters.
        q : ndarray, shape (n_free,)
            Free coordinates, m.
        u_motor : array_like, shape (m,)
            Motor angles, rad.

        Returns
        -------
        ndarray, shape (n_free, p)
            dg/dtheta in N per unit of each parameter.
        """
        fem, lay = self.fem(theta), self.layout
        theta = np.asarray(theta, float)
        x = fem.to_nodes(q)
        out = np.zeros((fem.n_free, lay.size))
        # Material: each tet's elastic force scaled by d ln E_t / d(ln s, g_y, g_z).
        el = fem.elastic.gradient(x)  # (M, 4, 3)
        scale = np.column_stack([np.ones(len(el)), self._section / (1.0 + self._section @ theta[1:3])[:, None]])
        dofs = (3 * self.mesh.tets[:, :, None] + np.arange(3)).ravel()
        for j in range(3):
            f = np.bincount(dofs, weights=(el * scale[:, j, None, None]).ravel(), minlength=3 * self.mesh.n_nodes)
            out[:, j] = f[fem.free_dofs]
        # Cables: slack shortens the stretch; shifts move eyelets, weights and rest length.
        d_slack, d_shift = fem.actuator("cables").geometry_force_derivative(
            x, np.asarray(u_motor, float), np.eye(3)[:, AXES[lay.axes]]
        )
        out[:, lay.slack] = d_slack
        for c, col in enumerate(d_shift):
            out[:, lay.shift(c)] = col
        return out

    def sensitivities(self, theta, q: np.ndarray, u_motor):
        """At an equilibrium q of the FEM at theta: dq/du (n_free, m) m/rad, dq/dtheta
        (n_free, p), and the tip Jacobians J_tip_u (3, m) and J_tip_theta (3, p), from one
        factorisation of the exact Hessian.

        Parameters
        ----------
        theta : array_like, shape (p,)
            The parameters.
        q : ndarray, shape (n_free,)
            An equilibrium of the FEM at theta, m.
        u_motor : array_like, shape (m,)
            Motor angles, rad.

        Returns
        -------
        dq_du : ndarray, shape (n_free, m)
            m/rad.
        dq_dtheta : ndarray, shape (n_free, p)
            m per unit of each parameter.
        J_tip_u : ndarray, shape (3, m)
            Tip in frame W, m/rad.
        J_tip_theta : ndarray, shape (3, p)
            Tip in frame W, m per unit of each parameter.
        """
        fem = self.fem(theta)
        lu = factorize(fem.hessian(q, u_motor))
        m = self.robot.n_cables
        dq = -lu.solve(np.hstack([fem.mixed_derivative(q, u_motor), self.force_derivative(theta, q, u_motor)]))
        J = fem.tip_matrix() @ dq
        return dq[:, :m], dq[:, m:], J[:, :m], J[:, m:]


def as_built_description(robot: RobotDescription, layout: ParameterLayout, theta) -> RobotDescription:
    """``robot`` at theta: modulus s E, ``stiffness_gradient`` [0, g], every cable's eyelets
    shifted (its anchor kept) and its ``slack_m`` set.

    Parameters
    ----------
    robot : RobotDescription
        The nominal robot.
    layout : ParameterLayout
        Where each parameter sits in theta.
    theta : array_like, shape (p,)
        The parameters.

    Returns
    -------
    RobotDescription
        The as-built robot.
    """
    v = layout.unpack(theta)
    cables = tuple(
        dataclasses.replace(c, via_points_m=c.via_points_m + d, slack_m=float(s))
        for c, d, s in zip(robot.cables, v["via_shift_m"], v["slack_m"])
    )
    return dataclasses.replace(
        robot,
        youngs_modulus_pa=robot.youngs_modulus_pa * v["softness"],
        stiffness_gradient=np.array([0.0, *v["gradient"]]),
        cables=cables,
    )


def robot_slack(robot: RobotDescription) -> np.ndarray:
    """The cables' ``slack_m`` (m,) in m."""
    return np.array([c.slack_m for c in robot.cables])
