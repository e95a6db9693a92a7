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
from dataclasses import dataclass

import numpy as np

from lab.description import RobotDescription
from lab.errors import InputError
from lab.fem.bodies.mesh import TetMesh, robot_mesh
from lab.fem.model import ArmFEM
from lab.fem.solve.linsolve import factorize
from lab.fem.solve.statics import StaticSolution, solve_static

#: The axes (of frame W) of each eyelet-shift option.
AXES = {"yz": (1, 2), "xyz": (0, 1, 2)}


class ParameterError(InputError):
    """Parameters outside the model: |g| >= 1, an eyelet shifted out of the mesh, non-finite."""


@dataclass(frozen=True)
class ParameterLayout:
    """Where each parameter sits in theta, for the cables ``cable_names`` and shift ``axes``."""

    cable_names: tuple[str, ...]
    axes: str = "yz"

    def __post_init__(self):
        if self.axes not in AXES:
            raise InputError(f"eyelet-shift axes must be one of {sorted(AXES)}, got {self.axes!r}")

    @property
    def n_cables(self) -> int:
        return len(self.cable_names)

    @property
    def size(self) -> int:
        """p = 3 + (a + 1) m."""
        return 3 + (len(AXES[self.axes]) + 1) * self.n_cables

    def shift(self, c: int) -> slice:
        """The slice of theta holding cable ``c``'s eyelet shift (a,) m."""
        a = len(AXES[self.axes])
        return slice(3 + a * c, 3 + a * (c + 1))

    @property
    def slack(self) -> slice:
        return slice(self.size - self.n_cables, self.size)

    @property
    def names(self) -> list[str]:
        """One name per parameter, e.g. ``via_shift_y_m[top]``."""
        out = ["log_softness", "gradient_y", "gradient_z"]
        out += [f"via_shift_{'xyz'[i]}_m[{n}]" for n in self.cable_names for i in AXES[self.axes]]
        return out + [f"slack_m[{n}]" for n in self.cable_names]

    @property
    def units(self) -> list[str]:
        return ["1"] * 3 + ["m"] * (self.size - 3)

    def pack(self, softness=1.0, gradient=(0.0, 0.0), via_shift_m=None, slack_m=None) -> np.ndarray:
        """theta (p,) from softness s > 0, gradient (g_y, g_z), shifts (m, 3) m in frame W and
        slack (m,) m. A shift along an axis the layout does not hold must be zero."""
        m, axes = self.n_cables, AXES[self.axes]
        shift = np.zeros((m, 3)) if via_shift_m is None else np.asarray(via_shift_m, float).reshape(m, 3)
        dropped = [i for i in range(3) if i not in axes]
        if np.any(shift[:, dropped]):
            raise ParameterError(f"eyelet shifts along x need axes='xyz', got {shift.tolist()}")
        slack = np.zeros(m) if slack_m is None else np.asarray(slack_m, float).reshape(m)
        return np.concatenate(
            [[np.log(softness)], np.asarray(gradient, float).reshape(2), shift[:, axes].ravel(), slack]
        )

    def unpack(self, theta) -> dict:
        """``{"softness", "gradient" (2,), "via_shift_m" (m, 3), "slack_m" (m,)}`` of theta."""
        theta = np.asarray(theta, float)
        if theta.shape != (self.size,):
            raise ParameterError(f"expected {self.size} parameters ({', '.join(self.names)}), got shape {theta.shape}")
        shift = np.zeros((self.n_cables, 3))
        shift[:, AXES[self.axes]] = theta[3 : self.slack.start].reshape(self.n_cables, -1)
        return {
            "softness": float(np.exp(theta[0])),
            "gradient": theta[1:3].copy(),
            "via_shift_m": shift,
            "slack_m": theta[self.slack].copy(),
        }


class ParametrisedFEM:
    """The FEM of ``robot`` as a function of theta (module docstring), on one fixed mesh
    (``mesh``, else ``n_rings``/``n_axial``, else the description's resolution)."""

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
        """:meth:`ParameterLayout.unpack`, refusing non-finite values or |g| >= 1."""
        theta = np.asarray(theta, float)
        if not np.all(np.isfinite(theta)):
            raise ParameterError(f"parameters must be finite, got {theta.tolist()}")
        v = self.layout.unpack(theta)
        if np.hypot(*v["gradient"]) >= 1:
            raise ParameterError(f"stiffness gradient |g| must be < 1, got {v['gradient'].tolist()}")
        return v

    def youngs_modulus(self, theta) -> np.ndarray:
        """Per-tet Young's modulus E_t (M,) in Pa."""
        v = self.check(theta)
        g = np.array([0.0, *v["gradient"]])
        return (self.robot.youngs_modulus_pa * v["softness"]) * (1.0 + self._centroids_W @ g / self.robot.radius_m)

    def description(self, theta) -> RobotDescription:
        """The robot description of the arm at theta (see :func:`as_built_description`)."""
        self.check(theta)
        return as_built_description(self.robot, self.layout, theta)

    def fem(self, theta) -> ArmFEM:
        """The :class:`ArmFEM` at theta (the last one is cached). Raises
        :class:`ParameterError` for an eyelet shifted out of the mesh."""
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
        """:func:`lab.fem.solve.statics.solve_static` of the FEM at theta."""
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
        factorisation of the exact Hessian."""
        fem = self.fem(theta)
        lu = factorize(fem.hessian(q, u_motor))
        m = self.robot.n_cables
        dq = -lu.solve(np.hstack([fem.mixed_derivative(q, u_motor), self.force_derivative(theta, q, u_motor)]))
        J = fem.tip_matrix() @ dq
        return dq[:, :m], dq[:, m:], J[:, :m], J[:, m:]


def as_built_description(robot: RobotDescription, layout: ParameterLayout, theta) -> RobotDescription:
    """``robot`` at theta: modulus s E, ``stiffness_gradient`` [0, g], every cable's eyelets
    shifted (its anchor kept) and its ``slack_m`` set."""
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
