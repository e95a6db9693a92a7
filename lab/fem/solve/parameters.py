"""The as-built arm as a parametrised FEM: parameters theta -> :class:`ArmFEM`, and dx/dtheta.

The same defects as the emulated as-built robot (``lab.asbuilt.arm``), as one vector
theta (p,) of the fitted groups (:mod:`lab.fem.solve.parameter_layout`; by default
``[ln s, g_y, g_z, delta_1, ..., delta_m, sigma_1, ..., sigma_m]``): log softness
``ln s`` (s = E_as-built / E), stiffness gradient ``g`` across the section (dimensionless,
|g| < 1), eyelet shift ``delta_c`` of cable c (m; (y, z) by default, (x, y, z) with
``axes="xyz"``; angle- and tension-controlled cables alike), slack ``sigma_c`` of an
angle-controlled cable (m, added to the free length: L* = L0 + sigma_c - r u) and the
density factor ``theta_rho`` (the body's mass, hence its gravity load, scaled by it).
A group not fitted keeps the description's value; the nominal theta gives exactly ``ArmFEM(robot)``.

Sensitivities: at an equilibrium dE/dq = 0, so dq/dtheta = -H^-1 dg/dtheta and
J_y_theta = S dq/dtheta (S the observed markers' rows of :meth:`ArmFEM.marker_matrix`), with
the exact Hessian H factorised once for dq/du and dq/dtheta together (as
:func:`lab.fem.solve.statics.sensitivities`) and the mixed derivative dg/dtheta analytic. The
gravity load is -theta_rho f_g (f_g the nominal nodal weights), so dg/dtheta_rho = -f_g =
-f_gravity(theta) / theta_rho on the free coordinates. A tension-controlled tendon's force
T dL/dq moves with its eyelets as T d(dL/dq)/d delta (its tension is held, so no spring term).

Each parameter, why (y, z) shifts by default (measured), and the derivatives: docs/design/fem.md.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from lab.description import RobotDescription
from lab.description.material import yeoh_small_strain
from lab.errors import InputError
from lab.fem.bodies import body_of
from lab.fem.bodies.mesh import TetMesh
from lab.fem.model import ArmFEM
from lab.fem.solve.linsolve import factorize
from lab.fem.solve.nearby import near_enough, nearby_sensitivities
from lab.fem.solve.parameter_layout import AXES, DEFAULT_GROUPS, ParameterError, ParameterLayout
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
        The rest mesh in frame W (m), clamped at its base; default the description's body.
    axes : str
        The eyelet shifts' axes, ``"yz"`` or ``"xyz"`` (see :class:`ParameterLayout`).
    groups : sequence of str
        The fitted groups (:data:`lab.fem.solve.parameter_layout.GROUPS`); default
        today's (softness, gradient, eyelets, slack). ``slack`` needs an angle-controlled cable.
    """

    def __init__(
        self,
        robot: RobotDescription,
        *,
        n_rings=None,
        n_axial=None,
        mesh: TetMesh | None = None,
        axes: str = "yz",
        groups=DEFAULT_GROUPS,
    ):
        self.robot = robot
        self.body = body_of(robot, n_rings=n_rings, n_axial=n_axial) if mesh is None else None  # fixed in theta
        self.mesh = mesh = self.body.mesh if mesh is None else mesh
        angle = tuple(i for i, c in enumerate(robot.cables) if c.control == "angle")
        if "slack" in groups and not angle:
            raise ParameterError(
                f"fit group 'slack' needs an angle-controlled cable (a spool's free length); robot {robot.name!r} "
                "has only tension-controlled tendons, whose held tension takes up any slack"
            )
        slack_cables = None if len(angle) == robot.n_cables else angle
        self.layout = ParameterLayout(tuple(c.name for c in robot.cables), axes, tuple(groups), slack_cables)
        self._centroids_W = mesh.X_W[mesh.tets].mean(axis=1)
        self._section = self._centroids_W[:, 1:] / robot.radius_m  # c_t / R (M, 2)
        self.nominal = self.layout.pack(
            gradient=robot.stiffness_gradient[1:], slack_m=[c.slack_m for c in robot.cables]
        )
        self._cached: tuple[bytes, ArmFEM] | None = None
        self.n_factorisations = 0  # by :meth:`sensitivities`

    def _gradient(self, v: dict) -> np.ndarray:
        """(g_y, g_z) at unpacked theta ``v``: fitted, else the description's."""
        return self.robot.stiffness_gradient[1:] if v["gradient"] is None else v["gradient"]

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
        if np.hypot(*self._gradient(v)) >= 1:
            raise ParameterError(f"stiffness gradient |g| must be < 1, got {self._gradient(v).tolist()}")
        if not v["density"] > 0:
            raise ParameterError(f"the density factor must be > 0, got {v['density']}")
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
        g = np.array([0.0, *self._gradient(v)])
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
                    None if self.body else self.mesh,
                    body=self.body,
                    youngs_modulus_pa=self.youngs_modulus(theta),
                    cable_slack_m=robot_slack(robot) if robot.all_angle else None,
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

        The material part scales each tet's elastic force; the gravity part is the nodal
        weights over theta_rho; the cables' slack and eyelet shifts come from
        each actuator's ``geometry_force_derivative`` (the angle cables' and the tension
        tendons').

        Parameters
        ----------
        theta : array_like, shape (p,)
            The parameters.
        q : ndarray, shape (n_free,)
            Free coordinates, m.
        u_motor : array_like, shape (m,)
            Inputs: motor angles (rad) and tensions (N), each in its cable's unit.

        Returns
        -------
        ndarray, shape (n_free, p)
            dg/dtheta in N per unit of each parameter.
        """
        fem, lay = self.fem(theta), self.layout
        theta = np.asarray(theta, float)
        v = lay.unpack(theta)
        x = fem.to_nodes(q)
        out = np.zeros((fem.n_free, lay.size))
        u = np.asarray(u_motor, float)
        # Material: each tet's elastic force scaled by d ln E_t / d(ln s, g_y, g_z).
        material = [g for g in ("softness", "gradient") if g in lay.groups]
        if material:
            el = fem.elastic.gradient(x)  # (M, 4, 3)
            cols = []
            if "softness" in material:
                cols.append(np.ones(len(el)))
            if "gradient" in material:
                cols += list((self._section / (1.0 + self._section @ self._gradient(v))[:, None]).T)
            scale = np.column_stack(cols)
            dofs = (3 * self.mesh.tets[:, :, None] + np.arange(3)).ravel()
            for j in range(scale.shape[1]):
                f = np.bincount(dofs, weights=(el * scale[:, j, None, None]).ravel(), minlength=3 * self.mesh.n_nodes)
                out[:, j] = f[fem.free_dofs]
        if "density" in lay.groups:  # gravity -theta_rho f_g: dg/dtheta_rho = -f_g
            out[:, lay.block("density")] = -(fem.f_gravity_W.ravel()[fem.free_dofs] / v["density"])[:, None]
        if not ({"eyelets", "slack"} & set(lay.groups)):
            return out
        P = np.eye(3)[:, AXES[lay.axes]]
        slack_col = {c: lay.slack.start + k for k, c in enumerate(lay.slack_indices)}
        for act in fem.actuators:  # slack shortens a cable's stretch; shifts move eyelets, weights, rest length
            if not hasattr(act, "geometry_force_derivative"):
                continue
            d_slack, d_shift = act.geometry_force_derivative(x, u[act.inputs], P)
            for k, c in enumerate(act.cable_indices):
                if "slack" in lay.groups and d_slack is not None:
                    out[:, slack_col[c]] = d_slack[:, k]
                if "eyelets" in lay.groups:
                    out[:, lay.shift(c)] = d_shift[k]
        return out

    def sensitivities(self, theta, q: np.ndarray, u_motor, markers=None, factorisation=None, *, fresh=True):
        """At an equilibrium q of the FEM at theta: dq/du (n_free, m), dq/dtheta
        (n_free, p), and the observed markers' Jacobians J_y_u (3K, m) and J_y_theta (3K, p)
        from one factorisation of the exact Hessian, or from ``factorisation``, the solve's
        own (:func:`lab.fem.solve.nearby.nearby_sensitivities`); with ``fresh=False`` None
        where that does not serve (no new factorisation: the caller may ask again later).

        Parameters
        ----------
        theta : array_like, shape (p,)
            The parameters.
        q : ndarray, shape (n_free,)
            An equilibrium of the FEM at theta, m.
        u_motor : array_like, shape (m,)
            Inputs (rad or N per cable).
        markers : sequence of int, optional
            Which of the FEM's markers (indices into ``fem.marker_names``, the tip is 0);
            default the tip alone (K = 1).
        factorisation : tuple, optional
            ``StaticSolution.factorisation`` of the solve that found q (``keep_factorisation``):
            no new factorisation where it serves.
        fresh : bool
            Factorise the Hessian at q where ``factorisation`` does not serve (else return None).

        Returns
        -------
        dq_du : ndarray, shape (n_free, m)
            m per unit of each input.
        dq_dtheta : ndarray, shape (n_free, p)
            m per unit of each parameter.
        J_y_u : ndarray, shape (3K, m)
            The markers in frame W, stacked (x, y, z) per marker, m per unit of each input.
        J_y_theta : ndarray, shape (3K, p)
            The same, m per unit of each parameter.
        """
        if not fresh and (factorisation is None or not near_enough(factorisation[0], factorisation[2])):
            return None  # (before the force derivatives: the caller asks again)
        fem = self.fem(theta)
        m = self.robot.n_inputs
        B = np.hstack([fem.mixed_derivative(q, u_motor), self.force_derivative(theta, q, u_motor)])
        S = marker_rows(fem, markers)
        got = None if factorisation is None else nearby_sensitivities(fem, q, u_motor, B, S, *factorisation)
        if got is None and not fresh:
            return None
        if got is None:
            self.n_factorisations += 1
            dq = -factorize(fem.hessian(q, u_motor)).solve(B)
            J = S @ dq
        else:
            dq, J = got
        return dq[:, :m], dq[:, m:], J[:, :m], J[:, m:]


def marker_rows(fem: ArmFEM, markers=None):
    """The rows of the observed markers as a linear map of the free coordinates.

    Parameters
    ----------
    fem : ArmFEM
        The model.
    markers : sequence of int, optional
        Indices into ``fem.marker_names`` (0 is the tip); default the tip alone.

    Returns
    -------
    scipy.sparse.csr_matrix, shape (3K, n_free)
        S with the markers' stacked positions = S q + const, m.
    """
    if markers is None or list(markers) == [0]:
        return fem.tip_matrix()
    rows = np.concatenate([3 * int(k) + np.arange(3) for k in markers])
    return fem.marker_matrix()[rows]


def as_built_description(robot: RobotDescription, layout: ParameterLayout, theta) -> RobotDescription:
    """``robot`` at theta: modulus s E, ``stiffness_gradient`` [0, g], every cable's eyelets
    shifted (its anchor kept), its ``slack_m`` set and the density scaled by theta_rho; a
    group the layout does not fit keeps the description's value.

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
    slack = [c.slack_m for c in robot.cables] if v["slack_m"] is None else v["slack_m"]
    cables = tuple(
        dataclasses.replace(c, via_points_m=c.via_points_m + d, slack_m=float(s))
        for c, d, s in zip(robot.cables, v["via_shift_m"], slack)
    )
    extra = {"density_kg_m3": robot.density_kg_m3 * v["density"]} if "density" in layout.groups else {}
    E = robot.youngs_modulus_pa * v["softness"]
    if robot.material_model == "yeoh":  # softness scales every coefficient of the law alike
        extra["yeoh_c_pa"] = tuple(float(v["softness"] * c) for c in robot.yeoh_c_pa)
        if robot.bulk_modulus_pa is not None:
            extra["bulk_modulus_pa"] = float(v["softness"] * robot.bulk_modulus_pa)
        # E and nu as the TOML reader derives them from the scaled law (bit for bit)
        E, extra["poisson_ratio"] = yeoh_small_strain(
            extra["yeoh_c_pa"][0],
            robot.poisson_ratio if robot.bulk_modulus_pa is None else None,
            extra.get("bulk_modulus_pa"),
        )
    return dataclasses.replace(
        robot,
        youngs_modulus_pa=E,
        stiffness_gradient=robot.stiffness_gradient if v["gradient"] is None else np.array([0.0, *v["gradient"]]),
        cables=cables,
        **extra,
    )


def robot_slack(robot: RobotDescription) -> np.ndarray:
    """The cables' ``slack_m`` (m,) in m."""
    return np.array([c.slack_m for c in robot.cables])
