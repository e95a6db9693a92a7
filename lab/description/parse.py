"""A parsed TOML document -> a validated :class:`~lab.description.robot.RobotDescription`.

:func:`parse_robot` checks every table and field, naming the first wrong one. The body is
read by :func:`parse_body` (a cylinder, a radius profile, or a mesh or CAD file that
:mod:`lab.description.geometry` reads and checks), the cables by :func:`parse_cable` (eyelets
given as via points or as an angle, an offset and stations), the observed points by
:func:`parse_markers`. Eyelets must lie inside the body; markers may sit outside it, on a
stalk or a ring (the body model says how far and how they move).
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from lab.description.chambers import check_chamber_geometry, parse_chamber, rest_volume_m3
from lab.description.fields import ROBOT_FIELDS, check_fields, get, points, refuse_unused, table, vec3
from lab.description.material import parse_material
from lab.description.robot import (
    FORMAT_VERSION,
    BodyShape,
    Cable,
    DescriptionError,
    MarkerSpec,
    RobotDescription,
    SafetyLimit,
)

#: The largest tension a tendon's bound may claim, N (beyond it a value is taken for a unit error).
TENSION_MAX_PLAUSIBLE_N = 10_000.0
#: Largest plausible ``actuation.u_max_rad``: ten turns of a spool (degrees read as radians exceed it).
MAX_U_MAX_RAD = 20 * np.pi
_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_-]*$")


def parse_body(body: dict, mesh: dict, base_dir: Path | None, chambered: bool = False):
    """The body's shape, length (m), largest radius (m) and mesh resolution.

    Parameters
    ----------
    body, mesh : dict
        The ``[body]`` and ``[mesh]`` tables.
    base_dir : pathlib.Path or None
        The description file's folder (``mesh_file`` is relative to it).
    chambered : bool
        Whether the robot has ``[[chambers]]``: a cylinder or tapered body is then meshed by
        gmsh at ``[mesh] size_m`` (the cavities left out) instead of the structured mesher.

    Returns
    -------
    shape : BodyShape
    length_m, radius_m : float
    n_rings, n_axial : int or None
        The structured mesher's resolution (None for a mesh body).
    """
    kind = body.get("shape")
    clamp = body.get("clamp", "base")
    size = None
    if kind in ("cylinder", "tapered"):
        refuse_unused(body, ("mesh_file", "mesh_unit", "clamp_group"), "body", f'by shape = "{kind}"')
        if clamp != "base":
            raise DescriptionError(f'field \'body.clamp\' must be "base" for shape = "{kind}", got {clamp!r}')
        if chambered:
            why = f'by a "{kind}" body with chambers (gmsh meshes it at mesh.size_m)'
            refuse_unused(mesh, ("n_rings", "n_axial", "order"), "mesh", why)
            size, n_rings, n_axial = get(mesh, "size_m", "mesh", positive=True), None, None
        else:
            refuse_unused(mesh, ("size_m", "order"), "mesh", f'by body.shape = "{kind}" (it takes n_rings, n_axial)')
            n_rings = get(mesh, "n_rings", "mesh", int, positive=True)
            n_axial = get(mesh, "n_axial", "mesh", int, positive=True)
    if kind == "cylinder":
        refuse_unused(body, ("profile_m",), "body", 'by shape = "cylinder" (use shape = "tapered")')
        length = get(body, "length_m", "body", positive=True)
        radius = get(body, "radius_m", "body", positive=True)
        if size is not None and not 0 < size < radius:
            raise DescriptionError(f"field 'mesh.size_m' = {size} m must be below the body's radius {radius} m")
        return BodyShape(mesh_size_m=size), length, radius, n_rings, n_axial
    if kind == "tapered":
        refuse_unused(body, ("length_m", "radius_m"), "body", 'by shape = "tapered" (profile_m gives them)')
        if "profile_m" not in body:
            raise DescriptionError("missing field 'body.profile_m' ([[x0, r0], [x1, r1], ...] in m)")
        profile = points(body, "profile_m", "body")
        if profile.ndim != 2 or profile.shape[1] != 2 or len(profile) < 2:
            raise DescriptionError("field 'body.profile_m' must be a list of at least two [x_m, r_m] stations")
        if profile[0, 0] != 0 or np.any(np.diff(profile[:, 0]) <= 0):
            raise DescriptionError(
                f"field 'body.profile_m' must start at x = 0 and increase in x, got x = {profile[:, 0].tolist()}"
            )
        if np.any(profile[:, 1] <= 0):
            raise DescriptionError(f"field 'body.profile_m' radii must be positive, got {profile[:, 1].tolist()}")
        shape = BodyShape(shape="tapered", profile_m=profile, mesh_size_m=size)
        return shape, float(profile[-1, 0]), float(profile[:, 1].max()), n_rings, n_axial
    if kind == "mesh":
        return _mesh_body(body, mesh, base_dir, clamp)
    raise DescriptionError(f'field \'body.shape\' must be "cylinder", "tapered" or "mesh", got {kind!r}')


def _mesh_body(body: dict, mesh: dict, base_dir: Path | None, clamp):
    from lab.description.geometry import MeshFileError, file_sha256, read_body_mesh

    refuse_unused(body, ("length_m", "radius_m", "profile_m"), "body", 'by shape = "mesh" (the mesh gives them)')
    refuse_unused(mesh, ("n_rings", "n_axial"), "mesh", 'by body.shape = "mesh" (it takes size_m, order)')
    rel = get(body, "mesh_file", "body", str)
    path = Path(rel) if base_dir is None else (base_dir / rel)
    unit = body.get("mesh_unit", "m")
    if unit not in ("m", "mm"):
        raise DescriptionError(f'field \'body.mesh_unit\' must be "m" or "mm", got {unit!r}')
    group = body.get("clamp_group")
    if group is not None:
        if "clamp" in body:
            raise DescriptionError("give either 'body.clamp' or 'body.clamp_group', not both")
        group, clamp = get(body, "clamp_group", "body", str), None
    elif clamp != "base":
        raise DescriptionError(f"field 'body.clamp' must be \"base\" (or give 'body.clamp_group'), got {clamp!r}")
    size = get(mesh, "size_m", "mesh", positive=True) if "size_m" in mesh else None
    order = get(mesh, "order", "mesh", int) if "order" in mesh else 1
    if order != 1:
        raise DescriptionError(f"field 'mesh.order' must be 1 (linear tetrahedra), got {order}")
    try:
        sha = file_sha256(path)
        shape = BodyShape("mesh", None, str(path.resolve()), sha, unit, size, order, clamp, group)
        body_mesh = read_body_mesh(shape)
    except MeshFileError as err:
        raise DescriptionError(str(err)) from None
    X = body_mesh.X_m
    length = float(X[:, 0].max() - X[:, 0].min())
    return shape, length, float(np.hypot(X[:, 1], X[:, 2]).max()), None, None


def parse_cable(entry: dict, i: int, robot_body: tuple) -> Cable:
    """One ``[[cables]]`` entry: its eyelets, anchor, slack and control.

    Parameters
    ----------
    entry : dict
        The table.
    i : int
        Its index (for the errors' ``cables[i]``).
    robot_body : tuple
        ``(shape, length_m, radius_at)``: the body's BodyShape, length (m) and a function of
        x (m) giving its radius (m), for the eyelets' checks (a mesh body checks them itself).

    Returns
    -------
    Cable
    """
    shape, length, radius_at = robot_body
    where = f"cables[{i}]"
    check_fields(entry, ROBOT_FIELDS["cables"], where)
    name = get(entry, "name", where, str)
    if "via_points_m" in entry:
        refuse_unused(entry, ("angle_deg", "offset_m", "stations_m"), where, "with via_points_m")
        pts = points(entry, "via_points_m", where)
        if pts.ndim != 2 or pts.shape[1] != 3 or len(pts) == 0:
            raise DescriptionError(f"field '{where}.via_points_m' must be a non-empty list of [x, y, z]")
    else:
        angle = math.radians(get(entry, "angle_deg", where))
        if "stations_m" not in entry or not isinstance(entry["stations_m"], list) or not entry["stations_m"]:
            raise DescriptionError(
                f"field '{where}.stations_m' must be a non-empty list of x positions (or give '{where}.via_points_m')"
            )
        xs = points(entry, "stations_m", where)
        if xs.ndim != 1:
            raise DescriptionError(f"field '{where}.stations_m' must be a list of numbers")
        if isinstance(entry.get("offset_m"), list):
            offset = points(entry, "offset_m", where)
            if offset.shape != xs.shape or np.any(offset <= 0):
                raise DescriptionError(
                    f"field '{where}.offset_m' must be one positive offset per station ({len(xs)}), got "
                    f"{entry['offset_m']!r}"
                )
        else:
            offset = np.full_like(xs, get(entry, "offset_m", where, positive=True))
        pts = np.column_stack([xs, offset * math.cos(angle), offset * math.sin(angle)])
    if np.any(pts[:, 0] <= 0) or np.any(pts[:, 0] > length + 1e-12):
        raise DescriptionError(f"{where}: via points must lie along the body, 0 < x <= body length {length} m")
    if shape.shape != "mesh":
        r = np.hypot(pts[:, 1], pts[:, 2])
        outside = np.flatnonzero(r > radius_at(pts[:, 0]) + 1e-12)
        if len(outside):
            k = int(outside[0])
            raise DescriptionError(
                f"{where}: via points must lie inside the body radius; via point {k} at x = {pts[k, 0]} m is "
                f"{r[k]} m off the axis, the radius there is {float(radius_at(pts[k, 0]))} m"
            )
    if np.any(np.diff(pts[:, 0]) <= 0):
        raise DescriptionError(f"{where}: via points must be ordered from base to tip (increasing x)")
    anchor = vec3(entry, "anchor_m", where) if "anchor_m" in entry else np.array([0.0, pts[0, 1], pts[0, 2]])
    control = entry.get("control", "angle")
    if control not in ("angle", "tension"):
        raise DescriptionError(f'field \'{where}.control\' must be "angle" or "tension", got {control!r}')
    tension_max = None
    if control == "tension":
        refuse_unused(entry, ("slack_m",), where, 'by control = "tension" (a tendon held at a tension has no slack)')
        tension_max = get(entry, "tension_max_n", where, positive=True)
        if tension_max > TENSION_MAX_PLAUSIBLE_N:
            raise DescriptionError(
                f"field '{where}.tension_max_n' = {tension_max} N is implausible for a tendon (over "
                f"{TENSION_MAX_PLAUSIBLE_N:.0f} N); is it in newtons?"
            )
    else:
        refuse_unused(entry, ("tension_max_n",), where, 'by control = "angle"')
    slack = get(entry, "slack_m", where) if "slack_m" in entry else 0.0
    if abs(slack) > 0.1 * length:
        raise DescriptionError(f"field '{where}.slack_m' must be within +-10 % of the body length, got {slack} m")
    return Cable(name, anchor, pts, slack, control, tension_max)


def parse_markers(entries, length: float) -> tuple[MarkerSpec, ...]:
    """The ``[[markers]]``: unique names (letters, digits, ``_``, ``-``; not ``tip``), finite positions (m).

    Parameters
    ----------
    entries : list of dict or None
        The tables.
    length : float
        The body's length, m (a marker beyond twice it is refused as a unit error).

    Returns
    -------
    tuple of MarkerSpec
    """
    if entries is None:
        return ()
    if not isinstance(entries, list):
        raise DescriptionError(f"field 'markers' must be a list of tables ([[markers]]), got {entries!r}")
    out = []
    for i, entry in enumerate(entries):
        where = f"markers[{i}]"
        check_fields(entry, ROBOT_FIELDS["markers"], where)
        name = get(entry, "name", where, str)
        if not _NAME.match(name) or name == "tip":
            raise DescriptionError(
                f"field '{where}.name' must start with a letter and hold only letters, digits, '_' and '-', and not "
                f"be 'tip' (the tip marker), got {name!r}"
            )
        if name in (m.name for m in out):
            raise DescriptionError(f"field '{where}.name' {name!r} is used twice; marker names must be unique")
        p = vec3(entry, "position_m", where)
        if np.linalg.norm(p) > 2 * length:
            raise DescriptionError(
                f"field '{where}.position_m' {p.tolist()} m is farther than twice the body's length from its base; "
                "is it in metres?"
            )
        out.append(MarkerSpec(name, p))
    return tuple(out)


def parse_robot(data: dict, base_dir: str | Path | None = None) -> RobotDescription:
    """Validate a parsed TOML document (a dict) and build the description.

    Parameters
    ----------
    data : dict
        The parsed TOML document.
    base_dir : str or pathlib.Path, optional
        The folder of the file it came from (``body.mesh_file`` is relative to it).

    Returns
    -------
    RobotDescription
    """
    check_fields(data, ROBOT_FIELDS[""], "")
    version = data.get("format_version")
    if version != FORMAT_VERSION:
        raise DescriptionError(f"field 'format_version' must be {FORMAT_VERSION}, got {version!r}")
    name = get(data, "name", "", str)
    base_dir = None if base_dir is None else Path(base_dir)
    chamber_entries = data.get("chambers")
    if chamber_entries is not None and (not isinstance(chamber_entries, list) or not chamber_entries):
        raise DescriptionError(
            f"field 'chambers' must be a non-empty list of tables ([[chambers]]), got {chamber_entries!r}"
        )
    shape, length, radius, n_rings, n_axial = parse_body(
        table(data, "body"), table(data, "mesh"), base_dir, chambered=bool(chamber_entries)
    )
    material = parse_material(table(data, "material"))
    gravity = vec3(table(data, "mounting"), "gravity_m_s2", "mounting")

    def radius_at(x):
        if shape.profile_m is None:
            return np.full(np.shape(x), radius) if np.ndim(x) else radius
        return np.interp(x, shape.profile_m[:, 0], shape.profile_m[:, 1])

    chambers = parse_chambers(chamber_entries, shape, length, radius_at)
    entries = data.get("cables")
    if entries is None and chambers:
        entries = []
    elif not isinstance(entries, list) or not entries:
        raise DescriptionError("missing [[cables]]: a robot needs at least one cable or chamber ([[chambers]])")
    cables = tuple(parse_cable(c, i, (shape, length, radius_at)) for i, c in enumerate(entries))
    names = [c.name for c in cables] + [c.name for c in chambers]
    if len(set(names)) != len(names):
        raise DescriptionError(f"cables[].name and chambers[].name must be unique together, got {names}")

    any_angle = any(c.control == "angle" for c in cables)
    act = table(data, "actuation", required=any_angle)
    keys = ("spool_radius_m", "u_max_rad", "cable_stiffness_n_m", "slack_smoothing_m")
    spool, u_max, k_cable, eps = (
        get(act, k, "actuation", positive=True) if k in act or any_angle else None for k in keys
    )
    if u_max is not None and u_max > MAX_U_MAX_RAD:
        raise DescriptionError(f"field 'actuation.u_max_rad' = {u_max} rad is more than ten turns of the spool; in "
                               f"degrees? ({u_max} deg = {np.radians(u_max):.4g} rad)")  # fmt: skip

    p_tip = vec3(table(data, "tip_marker"), "position_m", "tip_marker")
    # The tip marker must be on the body, or embedding it in the mesh fails later, far from here.
    tol = 1e-6 * length
    if shape.shape != "mesh" and (
        not (-tol <= p_tip[0] <= length + tol) or np.hypot(p_tip[1], p_tip[2]) > radius_at(p_tip[0]) + tol
    ):
        size = "body.radius_m = " if shape.shape == "cylinder" else "the profile's radius there, "
        raise DescriptionError(
            f"field 'tip_marker.position_m' {p_tip.tolist()} lies outside the body "
            f"(0 <= x <= body length = {length}, sqrt(y^2 + z^2) <= {size}{float(radius_at(p_tip[0]))})"
        )
    markers = parse_markers(data.get("markers"), length)

    limits = []
    entries = table(data, "safety", required=False).get("limits", [])
    if not isinstance(entries, list):
        raise DescriptionError(
            f"field 'safety.limits' must be a list of tables ([[safety.limits]]), got {type(entries).__name__} "
            f"{entries!r}"
        )
    angle_idx = [j for j, c in enumerate(cables) if c.control == "angle"]
    for i, lim in enumerate(entries):
        where = f"safety.limits[{i}]"
        check_fields(lim, ROBOT_FIELDS["safety.limits"], where)
        idx = lim.get("cables")
        if not isinstance(idx, list) or not idx or not all(isinstance(j, int) and 0 <= j < len(cables) for j in idx):
            raise DescriptionError(f"field '{where}.cables' must list cable indices in 0..{len(cables) - 1}")
        if any(j not in angle_idx for j in idx):
            raise DescriptionError(f"field '{where}.cables' must list angle-controlled cables only, got {idx}")
        limits.append(SafetyLimit(tuple(idx), get(lim, "max_sum_over_u_max", where, positive=True)))

    return RobotDescription(
        name=name,
        summary=str(data.get("summary", "")),
        length_m=length,
        radius_m=radius,
        youngs_modulus_pa=material.youngs_modulus_pa,
        poisson_ratio=material.poisson_ratio,
        density_kg_m3=material.density_kg_m3,
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
        stiffness_gradient=material.stiffness_gradient,
        body_shape=shape,
        markers=markers,
        chambers=chambers,
        material_model=material.model,
        yeoh_c_pa=material.yeoh_c_pa,
        bulk_modulus_pa=material.bulk_modulus_pa,
    )


def parse_chambers(entries, shape, length: float, radius_at) -> tuple:
    """The ``[[chambers]]``: each checked (:func:`~lab.description.chambers.parse_chamber`),
    then, in a cylinder or tapered body, against the body and one another at the mesh size.

    Parameters
    ----------
    entries : list of dict or None
        The tables.
    shape : BodyShape
        The body (its kind and ``mesh_size_m``).
    length : float
        The body's length, m.
    radius_at : callable
        x (m) -> the body's radius there, m.

    Returns
    -------
    tuple of Chamber
    """
    if not entries:
        return ()
    chambers = tuple(parse_chamber(c, i, shape.shape) for i, c in enumerate(entries))
    if shape.shape != "mesh":
        check_chamber_geometry(chambers, length, radius_at, shape.mesh_size_m)
    for i, c in enumerate(chambers):
        v0 = rest_volume_m3(c)
        if c.control == "volume" and v0 is not None and c.bounds[0] <= -v0:
            raise DescriptionError(
                f"field 'chambers[{i}].volume_min_m3' = {c.bounds[0]} m^3 would collapse the cavity (its rest volume "
                f"is {v0:.4g} m^3)"
            )
    return chambers
