"""The validated, immutable description of a robot: its body, material, cables and markers.

:class:`RobotDescription` is what :func:`lab.description.load_robot` returns. The body is
:class:`BodyShape`: today's cylinder, a solid of revolution given by a radius profile
(``"tapered"``), or a tetrahedral mesh or CAD geometry file (``"mesh"``). Each
:class:`Cable` is controlled by its spool angle (rad) or by its tension (N); the inputs u of
the robot are its cables in file order, each in its own unit (:attr:`RobotDescription.input_units`)
and range (:attr:`RobotDescription.u_upper`). The observed points are the tip marker, then the
named :class:`MarkerSpec` in file order (:attr:`RobotDescription.marker_names`).

Optional fields left at their defaults (an as-built gradient or slack of zero, a cylinder
body, no extra markers, angle control) do not change :attr:`RobotDescription.sha256`, so
the hash of a description written before they existed is unchanged.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field

import numpy as np

from lab.errors import InputError

FORMAT_VERSION = 1


class DescriptionError(InputError):
    """A robot description file is missing a field or has an invalid value."""


@dataclass(frozen=True)
class Cable:
    """One cable: fixed anchor in the base plate, then eyelets (via points) in the body.

    Parameters
    ----------
    name : str
        Its name (unique in the robot).
    anchor_m : ndarray, shape (3,)
        Where it leaves the base towards its spool or its load, frame W, m.
    via_points_m : ndarray, shape (K, 3)
        The eyelets' rest positions in frame W, m; the last is where it is tied off.
    slack_m : float
        Free length beyond taut at rest, m (an as-built field; negative: pre-tensioned).
    control : str
        ``"angle"`` (the input is the spool angle, rad) or ``"tension"`` (the input is the
        tension, N).
    tension_max_n : float or None
        The largest tension of a tension-controlled cable, N.
    """

    name: str
    anchor_m: np.ndarray
    via_points_m: np.ndarray
    slack_m: float = 0.0  # free length beyond taut at rest, m (optional field)
    control: str = "angle"
    tension_max_n: float | None = None


@dataclass(frozen=True)
class SafetyLimit:
    """Forbid commands with ``sum(u[cables]) > max_sum_over_u_max * u_max``.

    Parameters
    ----------
    cables : tuple of int
        Indices of angle-controlled cables.
    max_sum_over_u_max : float
        The largest sum of their angles, in units of ``u_max_rad``.
    """

    cables: tuple[int, ...]
    max_sum_over_u_max: float


@dataclass(frozen=True)
class BodyShape:
    """The body's geometry, frame W at rest, the base at x = 0 (m).

    Parameters
    ----------
    shape : str
        ``"cylinder"`` (the description's length and radius), ``"tapered"`` or ``"mesh"``.
    profile_m : ndarray, shape (S, 2), optional
        A tapered body's stations [x, r], m; the radius is piecewise linear between them.
    mesh_file : str, optional
        A mesh body's file (absolute path): a tet mesh (meshio) or a geometry (gmsh).
    mesh_sha256 : str, optional
        The file's content hash (the description's hash uses it, not the path).
    mesh_unit : str
        The file's length unit, ``"m"`` or ``"mm"``.
    mesh_size_m : float, optional
        Target element size of a meshed geometry, m.
    mesh_order : int
        Element order (1).
    clamp : str or None
        ``"base"``: the nodes at the smallest x are clamped.
    clamp_group : str or None
        Or: the nodes of this physical group of the file.
    """

    shape: str = "cylinder"
    profile_m: np.ndarray | None = None
    mesh_file: str | None = None
    mesh_sha256: str | None = None
    mesh_unit: str = "m"
    mesh_size_m: float | None = None
    mesh_order: int = 1
    clamp: str | None = "base"
    clamp_group: str | None = None


@dataclass(frozen=True)
class MarkerSpec:
    """A named observed point.

    Parameters
    ----------
    name : str
        Its name (letters, digits, ``_``, ``-``; not ``tip``); dataset columns ``NAME_x`` ...
    position_m : ndarray, shape (3,)
        Its position in the body frame at rest (frame W), m; inside the body or on a stalk.
    """

    name: str
    position_m: np.ndarray


#: Defaults that leave a description's hash as it was before the field existed.
_DEFAULTS = {
    "control": "angle",
    "tension_max_n": None,
    "markers": (),
    "chambers": (),
    "material_model": "neo-hookean",
    "yeoh_c_pa": None,
    "bulk_modulus_pa": None,
}


def _unset(obj, key: str) -> bool:
    """Whether ``key`` of ``obj`` is an optional field left at its default (or, for the
    mesh file's path, never hashed: the body is hashed by its content)."""
    value = getattr(obj, key)
    if key == "mesh_file":
        return True
    if key == "body_shape":
        return value.shape == "cylinder" and value.mesh_size_m is None
    if key in ("slack_m", "stiffness_gradient"):
        return not np.any(value)
    if key in _DEFAULTS:
        default = _DEFAULTS[key]
        return value is None if default is None else (value == default if not isinstance(value, tuple) else not value)
    return False


@dataclass(frozen=True)
class RobotDescription:
    """A robot: body, material, mounting, mesh, actuation, cables, markers and safety rules.

    Lengths in m, moduli in Pa, densities in kg/m^3, angles in rad, tensions in N.

    Parameters
    ----------
    name, summary : str
        The robot's name and one line about it.
    length_m, radius_m : float
        The body's length and largest radius, m (a tapered body: the last station and the
        largest radius; a mesh body: its extent along x and its largest distance from the axis).
    youngs_modulus_pa, poisson_ratio, density_kg_m3 : float
        The neo-Hookean material.
    gravity_m_s2 : ndarray, shape (3,)
        Gravity in frame W, m/s^2.
    n_rings, n_axial : int or None
        The structured mesher's resolution (None for a mesh body).
    spool_radius_m, u_max_rad, cable_stiffness_n_m, slack_smoothing_m : float or None
        The angle-controlled cables' actuation (None when every cable is tension-controlled).
    cables : tuple of Cable
        The cables, whose inputs are u in this order.
    p_tip_marker_W : ndarray, shape (3,)
        The tip marker, m, the first observed point.
    safety_limits : tuple of SafetyLimit
        The safety rules.
    source : dict
        The parsed TOML document.
    stiffness_gradient : ndarray, shape (3,)
        The as-built stiffness gradient [0, g_y, g_z].
    body_shape : BodyShape
        The body's geometry.
    markers : tuple of MarkerSpec
        The observed points after the tip.
    chambers : tuple of Chamber
        The fluid chambers, whose inputs follow the cables' in u.
    material_model : str
        ``"neo-hookean"`` or ``"yeoh"`` (then ``youngs_modulus_pa`` and ``poisson_ratio`` are
        its small-strain match).
    yeoh_c_pa : tuple of float or None
        The Yeoh law's (C10, C20, C30), Pa.
    bulk_modulus_pa : float or None
        The Yeoh law's bulk modulus when the file gives it instead of the Poisson ratio, Pa.
    """

    name: str
    summary: str
    length_m: float
    radius_m: float
    youngs_modulus_pa: float
    poisson_ratio: float
    density_kg_m3: float
    gravity_m_s2: np.ndarray
    n_rings: int | None
    n_axial: int | None
    spool_radius_m: float | None
    u_max_rad: float | None
    cable_stiffness_n_m: float | None
    slack_smoothing_m: float | None
    cables: tuple[Cable, ...]
    p_tip_marker_W: np.ndarray
    safety_limits: tuple[SafetyLimit, ...]
    source: dict = field(repr=False, compare=False)
    stiffness_gradient: np.ndarray = field(default_factory=lambda: np.zeros(3))  # (3,), x = 0
    body_shape: BodyShape = field(default_factory=BodyShape)
    markers: tuple[MarkerSpec, ...] = ()
    chambers: tuple = ()
    material_model: str = "neo-hookean"
    yeoh_c_pa: tuple | None = None
    bulk_modulus_pa: float | None = None

    @property
    def n_cables(self) -> int:
        """Number of cables."""
        return len(self.cables)

    @property
    def n_inputs(self) -> int:
        """Number of inputs u: the cables, then the chambers."""
        return len(self.cables) + len(self.chambers)

    @property
    def input_names(self) -> tuple[str, ...]:
        """The inputs' names: the cables', then the chambers', in file order."""
        return tuple(c.name for c in self.cables) + tuple(c.name for c in self.chambers)

    @property
    def input_units(self) -> tuple[str, ...]:
        """The unit of each input: ``"rad"`` (spool angle), ``"N"`` (tension), ``"Pa"``
        (gauge pressure) or ``"m^3"`` (fluid volume)."""
        cables = tuple("N" if c.control == "tension" else "rad" for c in self.cables)
        return cables + tuple(c.unit for c in self.chambers)

    @property
    def u_lower(self) -> np.ndarray:
        """The smallest value of each input (n_inputs,): zero angle or tension, a chamber's minimum."""
        return np.array([0.0] * self.n_cables + [c.bounds[0] for c in self.chambers], float)

    @property
    def u_upper(self) -> np.ndarray:
        """The largest value of each input (n_inputs,): ``u_max_rad`` (rad), ``tension_max_n`` (N),
        or a chamber's ``pressure_max_pa`` (Pa) or ``volume_max_m3`` (m^3)."""
        cables = [c.tension_max_n if c.control == "tension" else self.u_max_rad for c in self.cables]
        return np.array(cables + [c.bounds[1] for c in self.chambers], float)

    @property
    def all_angle(self) -> bool:
        """Whether every input is a cable's spool angle (the paper's robots)."""
        return not self.chambers and all(c.control == "angle" for c in self.cables)

    @property
    def marker_names(self) -> tuple[str, ...]:
        """The observed points: ``"tip"`` first, then the named markers in file order."""
        return ("tip",) + tuple(m.name for m in self.markers)

    @property
    def output_columns(self) -> list[str]:
        """The output columns of a dataset: ``x, y, z``, then ``NAME_x, NAME_y, NAME_z`` per marker."""
        return ["x", "y", "z"] + [f"{m.name}_{a}" for m in self.markers for a in "xyz"]

    def radius_at(self, x_m) -> np.ndarray:
        """The body's radius at positions x along its axis (cylinder or tapered), m.

        Parameters
        ----------
        x_m : array_like
            Positions along +x, m.

        Returns
        -------
        ndarray
            The radius there, m (shaped as ``x_m``).
        """
        profile = self.body_shape.profile_m
        if profile is None:
            return np.full(np.shape(x_m), self.radius_m)
        return np.interp(x_m, profile[:, 0], profile[:, 1])

    def youngs_modulus_at(self, points_W):
        """Young's modulus at points.

        Parameters
        ----------
        points_W : array_like, shape (P, 3)
            Points in frame W, m.

        Returns
        -------
        float or ndarray, shape (P,)
            The modulus in Pa: a scalar without a stiffness gradient.
        """
        if not np.any(self.stiffness_gradient):
            return self.youngs_modulus_pa
        return self.youngs_modulus_pa * (1.0 + np.asarray(points_W) @ self.stiffness_gradient / self.radius_m)

    @property
    def sha256(self) -> str:
        """Hash of every field (stable across comments and formatting of the file, and
        different for a description modified in code with ``dataclasses.replace``)."""

        def plain(v):
            if isinstance(v, np.ndarray):
                return v.tolist()
            if isinstance(v, (tuple, list)):
                return [plain(x) for x in v]
            if hasattr(v, "__dataclass_fields__"):  # optional fields left unset do not count
                return {k: plain(getattr(v, k)) for k in v.__dataclass_fields__ if not _unset(v, k)}
            return v

        fields = {k: v for k, v in plain(self).items() if k not in ("source", "summary")}
        return hashlib.sha256(json.dumps(fields, sort_keys=True).encode()).hexdigest()

    def is_safe(self, u_motor, tol: float = 1e-9) -> np.ndarray:
        """Whether inputs satisfy the safety rule and their ranges ``[u_lower, u_upper]``.

        Parameters
        ----------
        u_motor : array_like, shape (m,) or (N, m)
            Inputs, each in its unit (rad or N).
        tol : float
            Relative slack on each bound.

        Returns
        -------
        bool or ndarray of bool, shape (N,)
            Whether each command is allowed.
        """
        u = np.atleast_2d(np.asarray(u_motor, dtype=float))
        if u.shape[1] != self.n_inputs:
            raise InputError(f"expected {self.n_inputs} inputs, got {u.shape[1]}")
        slack = tol * np.maximum(np.abs(self.u_upper), np.abs(self.u_lower))
        ok = np.all(np.isfinite(u), axis=1)
        ok &= np.all((u >= self.u_lower - slack) & (u <= self.u_upper + slack), axis=1)
        for lim in self.safety_limits:
            ok &= u[:, list(lim.cables)].sum(axis=1) <= lim.max_sum_over_u_max * self.u_max_rad + tol * self.u_max_rad
        return ok if np.ndim(u_motor) == 2 else bool(ok[0])

    def check_command(self, u_motor) -> np.ndarray:
        """Check one command.

        Parameters
        ----------
        u_motor : array_like, shape (m,)
            Inputs, each in its unit (rad or N).

        Returns
        -------
        ndarray, shape (m,)
            The command as floats (InputError saying what is wrong otherwise).
        """
        u = np.asarray(u_motor, dtype=float)
        what = "motor angles" if self.all_angle else "inputs"
        if u.shape != (self.n_inputs,):
            raise InputError(f"{self.name}: expected {self.n_inputs} {what}, got shape {u.shape}")
        if not np.all(np.isfinite(u)):
            raise InputError(f"{self.name}: {what} must be finite, got {u.tolist()}")
        if self.all_angle:
            if np.any(u < -1e-9) or np.any(u > self.u_max_rad * (1 + 1e-9)):
                raise InputError(f"{self.name}: motor angles {u.tolist()} rad outside [0, {self.u_max_rad}]")
        else:
            low, high = self.u_lower, self.u_upper
            slack = 1e-9 * np.maximum(np.abs(low), np.abs(high))
            bad = np.flatnonzero((u < low - slack) | (u > high + slack))
            if len(bad):
                i = int(bad[0])
                kind = "cable" if i < self.n_cables else "chamber"
                unit = self.input_units[i]
                raise InputError(
                    f"{self.name}: input {i} ({kind} '{self.input_names[i]}') {u[i]} {unit} outside "
                    f"[{low[i]:g}, {high[i]}] {unit}"
                )
        if not self.is_safe(u):
            raise InputError(f"{self.name}: motor command {u.tolist()} rad violates the safety rule")
        return u
