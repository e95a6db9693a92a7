"""Robot descriptions: a TOML file -> a validated, immutable :class:`RobotDescription`.

A description says everything the simulator needs about a cable-driven arm: body
geometry, material, mounting (gravity), default mesh resolution, actuation (spool
radius, motor range, cable spring), the cable routes through eyelets (via points),
the tip marker, and the safety rule that forbids too-aggressive motor commands.

Shipped descriptions live in ``lab/robots/<name>.toml``; :func:`load_robot` accepts
either such a name (``"three-cable"``) or a path to a user's own file. Every field is
checked and a bad file raises :class:`DescriptionError` naming the field.

Optional as-built fields (``python -m lab calibrate`` writes them; absent, nothing changes,
not even :attr:`sha256`): ``material.stiffness_gradient = [0, g_y, g_z]``, E(p) =
youngs_modulus_pa (1 + g . p / radius_m), |g| < 1; ``cables[].slack_m``, free length beyond
taut at rest in m (negative: pre-tensioned), within +-10 % of the body length.
"""

from __future__ import annotations

import difflib
import hashlib
import json
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from lab.errors import InputError

FORMAT_VERSION = 1
ROBOTS_DIR = Path(__file__).with_name("robots")


class DescriptionError(InputError):
    """A robot description file is missing a field or has an invalid value."""


@dataclass(frozen=True)
class Cable:
    """One cable: fixed anchor in the base plate, then eyelets (via points) in the body.

    ``via_points_m`` (K, 3) are rest positions in frame W; the last one is where the
    cable is tied off. ``anchor_m`` (3,) is where it leaves the base towards its spool.
    """

    name: str
    anchor_m: np.ndarray
    via_points_m: np.ndarray
    slack_m: float = 0.0  # free length beyond taut at rest, m (optional field)


@dataclass(frozen=True)
class SafetyLimit:
    """Forbid commands with ``sum(u[cables]) > max_sum_over_u_max * u_max``."""

    cables: tuple[int, ...]
    max_sum_over_u_max: float


@dataclass(frozen=True)
class RobotDescription:
    name: str
    summary: str
    length_m: float
    radius_m: float
    youngs_modulus_pa: float
    poisson_ratio: float
    density_kg_m3: float
    gravity_m_s2: np.ndarray
    n_rings: int
    n_axial: int
    spool_radius_m: float
    u_max_rad: float
    cable_stiffness_n_m: float
    slack_smoothing_m: float
    cables: tuple[Cable, ...]
    p_tip_marker_W: np.ndarray
    safety_limits: tuple[SafetyLimit, ...]
    source: dict = field(repr=False, compare=False)
    stiffness_gradient: np.ndarray = field(default_factory=lambda: np.zeros(3))  # (3,), x = 0

    @property
    def n_cables(self) -> int:
        return len(self.cables)

    def youngs_modulus_at(self, points_W):
        """Young's modulus in Pa at points (P, 3) m: a scalar without a stiffness gradient, else (P,)."""
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
        """Whether motor commands satisfy the safety rule and the range ``[0, u_max]``.

        ``u_motor``: (m,) or (N, m) radians. Returns a bool, or (N,) bools.
        """
        u = np.atleast_2d(np.asarray(u_motor, dtype=float))
        if u.shape[1] != self.n_cables:
            raise InputError(f"expected {self.n_cables} motor angles, got {u.shape[1]}")
        slack = tol * self.u_max_rad
        ok = np.all(np.isfinite(u), axis=1)
        ok &= np.all((u >= -slack) & (u <= self.u_max_rad + slack), axis=1)
        for lim in self.safety_limits:
            ok &= u[:, list(lim.cables)].sum(axis=1) <= lim.max_sum_over_u_max * self.u_max_rad + slack
        return ok if np.ndim(u_motor) == 2 else bool(ok[0])

    def check_command(self, u_motor) -> np.ndarray:
        """Return ``u_motor`` as a float array or raise ValueError saying what is wrong."""
        u = np.asarray(u_motor, dtype=float)
        if u.shape != (self.n_cables,):
            raise InputError(f"{self.name}: expected {self.n_cables} motor angles, got shape {u.shape}")
        if not np.all(np.isfinite(u)):
            raise InputError(f"{self.name}: motor angles must be finite, got {u.tolist()}")
        if np.any(u < -1e-9) or np.any(u > self.u_max_rad * (1 + 1e-9)):
            raise InputError(f"{self.name}: motor angles {u.tolist()} rad outside [0, {self.u_max_rad}]")
        if not self.is_safe(u):
            raise InputError(f"{self.name}: motor command {u.tolist()} rad violates the safety rule")
        return u


def _unset(obj, key: str) -> bool:
    """Whether ``key`` is an optional as-built field of ``obj`` left at its default (zero)."""
    return key in ("slack_m", "stiffness_gradient") and not np.any(getattr(obj, key))


def check_fields(table, allowed, where: str, error: type[Exception] = None) -> dict:
    """Refuse a table that is not a table, or that has a field not in ``allowed`` -- a
    misspelt field would otherwise be ignored silently -- naming the closest valid name.
    ``where`` names the table (``"material"``, ``"cables[1]"``; ``""`` for the top level).
    Shared by the robot, defects and hardware-config readers. Returns ``table``."""
    error = error or DescriptionError
    label = f"[{where}]" if where else "the top level"
    if not isinstance(table, dict):
        raise error(f"{label} must be a table, got {type(table).__name__} {table!r}")
    for key in table:
        if key not in allowed:
            close = difflib.get_close_matches(key, list(allowed), n=1, cutoff=0.6)
            hint = f"did you mean '{close[0]}'?" if close else f"known fields: {', '.join(sorted(allowed))}"
            raise error(f"{label} has no field '{key}' ({hint})")
    return table


#: The fields of each table of a robot description (optional ones included).
ROBOT_FIELDS = {
    "": {
        "format_version",
        "name",
        "summary",
        "body",
        "material",
        "mounting",
        "mesh",
        "actuation",
        "cables",
        "tip_marker",
        "safety",
    },
    "body": {"shape", "length_m", "radius_m"},
    "material": {"model", "youngs_modulus_pa", "poisson_ratio", "density_kg_m3", "stiffness_gradient"},
    "mounting": {"gravity_m_s2"},
    "mesh": {"n_rings", "n_axial"},
    "actuation": {"spool_radius_m", "u_max_rad", "cable_stiffness_n_m", "slack_smoothing_m"},
    "cables": {"name", "angle_deg", "offset_m", "stations_m", "via_points_m", "anchor_m", "slack_m"},
    "tip_marker": {"position_m"},
    "safety": {"limits"},
    "safety.limits": {"cables", "max_sum_over_u_max"},
}


def _get(table: dict, key: str, where: str, kind=float, positive: bool = False):
    if key not in table:
        raise DescriptionError(f"missing field '{where}.{key}'")
    value = table[key]
    try:
        if kind is float:
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise TypeError
            value = float(value)
            if not math.isfinite(value):
                raise ValueError
        elif kind is int:
            if isinstance(value, bool) or not isinstance(value, int):
                raise TypeError
        elif kind is str:
            if not isinstance(value, str):
                raise TypeError
    except (TypeError, ValueError):
        raise DescriptionError(f"field '{where}.{key}' must be a finite {kind.__name__}, got {value!r}") from None
    if positive and value <= 0:
        raise DescriptionError(f"field '{where}.{key}' must be positive, got {value!r}")
    return value


def _vec3(table: dict, key: str, where: str) -> np.ndarray:
    if key not in table:
        raise DescriptionError(f"missing field '{where}.{key}'")
    v = np.asarray(table[key], dtype=object)
    if v.shape != (3,) or not all(isinstance(c, (int, float)) and not isinstance(c, bool) for c in v):
        raise DescriptionError(f"field '{where}.{key}' must be a list of 3 numbers, got {table[key]!r}")
    v = v.astype(float)
    if not np.all(np.isfinite(v)):
        raise DescriptionError(f"field '{where}.{key}' must be finite, got {table[key]!r}")
    return v


def _table(data: dict, key: str) -> dict:
    t = data.get(key)
    if t is None:
        raise DescriptionError(f"missing table [{key}]")
    return check_fields(t, ROBOT_FIELDS[key], key)


def _points(entry: dict, key: str, where: str) -> np.ndarray:
    try:
        return np.asarray(entry[key], dtype=float)
    except (TypeError, ValueError):
        raise DescriptionError(f"field '{where}.{key}' must hold numbers, got {entry[key]!r}") from None


def _cable(entry: dict, i: int, length: float, radius: float) -> Cable:
    where = f"cables[{i}]"
    check_fields(entry, ROBOT_FIELDS["cables"], where)
    name = _get(entry, "name", where, str)
    if "via_points_m" in entry:
        pts = _points(entry, "via_points_m", where)
        if pts.ndim != 2 or pts.shape[1] != 3 or len(pts) == 0:
            raise DescriptionError(f"field '{where}.via_points_m' must be a non-empty list of [x, y, z]")
    else:
        angle = math.radians(_get(entry, "angle_deg", where))
        offset = _get(entry, "offset_m", where, positive=True)
        if "stations_m" not in entry or not isinstance(entry["stations_m"], list) or not entry["stations_m"]:
            raise DescriptionError(
                f"field '{where}.stations_m' must be a non-empty list of x positions (or give '{where}.via_points_m')"
            )
        xs = _points(entry, "stations_m", where)
        if xs.ndim != 1:
            raise DescriptionError(f"field '{where}.stations_m' must be a list of numbers")
        pts = np.column_stack(
            [xs, np.full_like(xs, offset * math.cos(angle)), np.full_like(xs, offset * math.sin(angle))]
        )
    if not np.all(np.isfinite(pts)):
        raise DescriptionError(f"{where}: via points must be finite")
    if np.any(pts[:, 0] <= 0) or np.any(pts[:, 0] > length + 1e-12):
        raise DescriptionError(f"{where}: via points must lie along the body, 0 < x <= body.length_m")
    if np.any(np.hypot(pts[:, 1], pts[:, 2]) > radius + 1e-12):
        raise DescriptionError(f"{where}: via points must lie inside the body radius {radius} m")
    if np.any(np.diff(pts[:, 0]) <= 0):
        raise DescriptionError(f"{where}: via points must be ordered from base to tip (increasing x)")
    anchor = _vec3(entry, "anchor_m", where) if "anchor_m" in entry else np.array([0.0, pts[0, 1], pts[0, 2]])
    slack = _get(entry, "slack_m", where) if "slack_m" in entry else 0.0
    if abs(slack) > 0.1 * length:
        raise DescriptionError(f"field '{where}.slack_m' must be within +-10 % of body.length_m, got {slack} m")
    return Cable(name=name, anchor_m=anchor, via_points_m=pts, slack_m=slack)


def parse_robot(data: dict) -> RobotDescription:
    """Validate a parsed TOML document (a dict) and build the description."""
    check_fields(data, ROBOT_FIELDS[""], "")
    version = data.get("format_version")
    if version != FORMAT_VERSION:
        raise DescriptionError(f"field 'format_version' must be {FORMAT_VERSION}, got {version!r}")
    name = _get(data, "name", "", str)
    body = _table(data, "body")
    if body.get("shape") != "cylinder":
        raise DescriptionError(f"field 'body.shape' must be \"cylinder\", got {body.get('shape')!r}")
    length = _get(body, "length_m", "body", positive=True)
    radius = _get(body, "radius_m", "body", positive=True)

    mat = _table(data, "material")
    if mat.get("model") != "neo-hookean":
        raise DescriptionError(f"field 'material.model' must be \"neo-hookean\", got {mat.get('model')!r}")
    E = _get(mat, "youngs_modulus_pa", "material", positive=True)
    nu = _get(mat, "poisson_ratio", "material")
    if not -1.0 < nu < 0.5:
        raise DescriptionError(f"field 'material.poisson_ratio' must be in (-1, 0.5), got {nu}")
    rho = _get(mat, "density_kg_m3", "material", positive=True)
    grad = _vec3(mat, "stiffness_gradient", "material") if "stiffness_gradient" in mat else np.zeros(3)
    if grad[0] != 0 or np.hypot(grad[1], grad[2]) >= 1:
        raise DescriptionError(
            f"field 'material.stiffness_gradient' must be [0, g_y, g_z], |g| < 1, got {grad.tolist()}"
        )

    gravity = _vec3(_table(data, "mounting"), "gravity_m_s2", "mounting")
    mesh = _table(data, "mesh")
    n_rings = _get(mesh, "n_rings", "mesh", int, positive=True)
    n_axial = _get(mesh, "n_axial", "mesh", int, positive=True)

    act = _table(data, "actuation")
    spool = _get(act, "spool_radius_m", "actuation", positive=True)
    u_max = _get(act, "u_max_rad", "actuation", positive=True)
    k_cable = _get(act, "cable_stiffness_n_m", "actuation", positive=True)
    eps = _get(act, "slack_smoothing_m", "actuation", positive=True)

    entries = data.get("cables")
    if not isinstance(entries, list) or not entries:
        raise DescriptionError("missing [[cables]]: a robot needs at least one cable")
    cables = tuple(_cable(c, i, length, radius) for i, c in enumerate(entries))
    names = [c.name for c in cables]
    if len(set(names)) != len(names):
        raise DescriptionError(f"cables[].name must be unique, got {names}")

    p_tip = _vec3(_table(data, "tip_marker"), "position_m", "tip_marker")
    # The marker must be on the body, or embedding it in the mesh fails later, far from here.
    tol = 1e-6 * length
    if not (-tol <= p_tip[0] <= length + tol) or np.hypot(p_tip[1], p_tip[2]) > radius + tol:
        raise DescriptionError(
            f"field 'tip_marker.position_m' {p_tip.tolist()} lies outside the body "
            f"(0 <= x <= body.length_m = {length}, sqrt(y^2 + z^2) <= body.radius_m = {radius})"
        )

    limits = []
    entries = _table(data, "safety").get("limits", [])
    if not isinstance(entries, list):
        raise DescriptionError(
            f"field 'safety.limits' must be a list of tables ([[safety.limits]]), got {type(entries).__name__} "
            f"{entries!r}"
        )
    for i, lim in enumerate(entries):
        where = f"safety.limits[{i}]"
        check_fields(lim, ROBOT_FIELDS["safety.limits"], where)
        idx = lim.get("cables")
        if not isinstance(idx, list) or not idx or not all(isinstance(j, int) and 0 <= j < len(cables) for j in idx):
            raise DescriptionError(f"field '{where}.cables' must list cable indices in 0..{len(cables) - 1}")
        limits.append(SafetyLimit(tuple(idx), _get(lim, "max_sum_over_u_max", where, positive=True)))

    return RobotDescription(
        name=name,
        summary=str(data.get("summary", "")),
        length_m=length,
        radius_m=radius,
        youngs_modulus_pa=E,
        poisson_ratio=nu,
        density_kg_m3=rho,
        gravity_m_s2=gravity,
        n_rings=n_rings,
        n_axial=n_axial,
        spool_radius_m=spool,
        u_max_rad=u_max,
        cable_stiffness_n_m=k_cable,
        slack_smoothing_m=eps,
        cables=cables,
        p_tip_marker_W=p_tip,
        safety_limits=tuple(limits),
        source=data,
        stiffness_gradient=grad,
    )


def read_toml(path: str | Path, error: type[Exception], what: str) -> dict:
    """Parse the TOML file ``path``; a missing or malformed file raises ``error`` naming
    the file (``what`` says which kind of file, e.g. "defects file")."""
    try:
        return tomllib.loads(Path(path).read_bytes().decode("utf-8"))
    except FileNotFoundError:
        raise error(f"{what} not found: {path}") from None
    except UnicodeDecodeError as err:
        raise error(
            f"{path}: not a TOML {what} (not UTF-8 text: byte {err.start} is 0x{err.object[err.start]:02x})"
        ) from None
    except tomllib.TOMLDecodeError as err:
        raise error(f"{path}: not valid TOML: {err}") from None


def load_robot(name_or_path: str | Path) -> RobotDescription:
    """Load a shipped robot by name (``"three-cable"``, ``"six-cable"``) or a TOML path."""
    path = Path(name_or_path)
    if not path.suffix and not path.exists():
        path = ROBOTS_DIR / f"{name_or_path}.toml"
        if not path.exists():
            shipped = sorted(p.stem for p in ROBOTS_DIR.glob("*.toml"))
            raise DescriptionError(f"unknown robot {str(name_or_path)!r}; shipped robots: {shipped}")
    data = read_toml(path, DescriptionError, "robot description file")
    try:
        return parse_robot(data)
    except DescriptionError as err:
        raise DescriptionError(f"{path}: {err}") from None


def shipped_robots() -> list[str]:
    return sorted(p.stem for p in ROBOTS_DIR.glob("*.toml"))
