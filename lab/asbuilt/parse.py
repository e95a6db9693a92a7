"""Reading a defects file: a parsed TOML document -> a validated :class:`Defects`.

:func:`parse_defects` checks every table against :data:`DEFECTS_FIELDS` (a misspelt field
is refused with the closest valid name) and every value against its range, raising
:class:`~lab.asbuilt.fields.DefectsError` naming the field (``load_defects`` in
:mod:`lab.asbuilt.arm` adds the file). The required tables (``[material]``,
``[[cables]]``, ``[lag]``, ``[motors]``, ``[mocap]``) are those ``calibrate`` and the twin
always needed; the optional fields outside the calibrator's model class (``[mount]``, the
mocap frame error, cable stiffness, creep, the hyperfoam law) come in pairs that must be
given together, and absent they leave the robot exactly as before. A robot with pressure
chambers needs one ``[[chambers]]`` table per chamber (cast-cavity errors, the silicone's
stiffness round it, its pressure regulator) and, without cables, no ``[[cables]]`` or
``[motors]``. The meaning and range
of each field: :mod:`lab.asbuilt.fields` and ``lab/rig/defects/three-cable.toml``.
"""

from __future__ import annotations

import math

import numpy as np

from lab.asbuilt.fields import (
    CABLE_STIFFNESS_RANGE_N_PER_M,
    CHAMBER_ANGLE_ERROR_LIMIT_DEG,
    CHAMBER_OFFSET_ERROR_LIMIT_M,
    CHAMBER_RADIUS_ERROR_LIMIT_M,
    CHAMBER_STIFFNESS_RANGE,
    CREEP_TAU_LIMIT_S,
    FRAME_OFFSET_LIMIT_M,
    FRAME_ROTATION_RANGE_DEG,
    HYPERFOAM_ALPHA_LIMIT,
    HYPERFOAM_BETA_LIMIT,
    LAWS,
    REGULATOR_DEAD_TIME_RANGE_S,
    REGULATOR_GAIN_RANGE,
    REGULATOR_OFFSET_LIMIT_FS,
    REGULATOR_TAU_RANGE_S,
    TILT_RANGE_DEG,
    CableDefects,
    ChamberDefects,
    Defects,
    DefectsError,
    num,
    ranged,
    vec3,
)
from lab.description import RobotDescription, check_fields

FORMAT_VERSION = 1
HYPERFOAM_FIELDS = ("hyperfoam_mu_pa", "hyperfoam_alpha", "hyperfoam_beta")

#: The fields of each table of a defects file (optional ones included).
DEFECTS_FIELDS = {
    "": {"format_version", "robot", "material", "cables", "lag", "motors", "mocap", "emulator", "mount", "chambers"},
    "material": {"softness", "gradient", "gradient_direction", "law", *HYPERFOAM_FIELDS},
    "cables": {"name", "via_shift_m", "slack_m", "play_m", "stiffness_n_per_m"},
    "lag": {"tau_fast_s", "tau_slow_s", "slow_fraction", "creep_fraction", "creep_tau_s"},
    "motors": {"ticks_per_rev", "profile_velocity_rad_s"},
    "mocap": {
        "frame_rate_hz",
        "noise_sigma_m",
        "dropout_rate_hz",
        "dropout_max_frames",
        "frame_rotation_deg",
        "frame_rotation_axis",
        "frame_offset_m",
    },
    "emulator": {"n_rings", "n_axial"},
    "mount": {"tilt_deg", "tilt_axis"},
    "chambers": {
        "name",
        "offset_error_m",
        "angle_error_deg",
        "radius_error_m",
        "stiffness",
        "regulator_tau_s",
        "regulator_dead_time_s",
        "regulator_gain",
        "regulator_offset_pa",
    },
}


def _table(data: dict, key: str) -> dict:
    t = data.get(key)
    if t is None:
        raise DefectsError(f"missing table [{key}]")
    return check_fields(t, DEFECTS_FIELDS[key], key, DefectsError)


def _together(table: dict, keys: tuple[str, ...], where: str) -> bool:
    """Whether the optional fields ``keys`` are given; refuses a partial set."""
    given = [k for k in keys if k in table]
    if given and len(given) < len(keys):
        missing = [k for k in keys if k not in table]
        raise DefectsError(
            f"missing field '{where}.{missing[0]}': {', '.join(repr(f'{where}.{k}') for k in keys)} "
            f"are given together ('{where}.{given[0]}' is set)"
        )
    return bool(given)


def _cables(data: dict, robot: RobotDescription) -> tuple[CableDefects, ...]:
    if robot.n_cables == 0 and "cables" not in data:  # a robot driven by its chambers alone
        return ()
    entries = data.get("cables")
    if not isinstance(entries, list) or len(entries) != robot.n_cables:
        raise DefectsError(
            f"[[cables]] must have one table per cable of {robot.name} "
            f"({robot.n_cables}), got {len(entries) if isinstance(entries, list) else 0}"
        )
    cables = []
    for i, (entry, cable) in enumerate(zip(entries, robot.cables)):
        where = f"cables[{i}]"
        check_fields(entry, DEFECTS_FIELDS["cables"], where, DefectsError)
        if entry.get("name") != cable.name:
            got = entry.get("name") if isinstance(entry, dict) else entry
            raise DefectsError(f"field '{where}.name' must be {cable.name!r} (the description's order), got {got!r}")
        shift = vec3(entry, "via_shift_m", where)
        slack, play = num(entry, "slack_m", where, lo=0.0), num(entry, "play_m", where, lo=0.0)
        k = None
        if "stiffness_n_per_m" in entry:
            k = ranged(entry, "stiffness_n_per_m", where, *CABLE_STIFFNESS_RANGE_N_PER_M, " N/m")
        cables.append(CableDefects(cable.name, shift, slack, play, k))
    return tuple(cables)


def _chambers(data: dict, robot: RobotDescription) -> tuple[ChamberDefects, ...]:
    chambers = tuple(getattr(robot, "chambers", ()))
    if not chambers:
        if "chambers" in data:
            raise DefectsError(f"[[chambers]]: robot {robot.name!r} has no chambers (remove the tables)")
        return ()
    entries = data.get("chambers")
    if not isinstance(entries, list) or len(entries) != len(chambers):
        raise DefectsError(
            f"[[chambers]] must have one table per chamber of {robot.name} "
            f"({len(chambers)}), got {len(entries) if isinstance(entries, list) else 0}"
        )
    out = []
    for i, (entry, chamber) in enumerate(zip(entries, chambers)):
        where = f"chambers[{i}]"
        check_fields(entry, DEFECTS_FIELDS["chambers"], where, DefectsError)
        if entry.get("name") != chamber.name:
            raise DefectsError(
                f"field '{where}.name' must be {chamber.name!r} (the description's order), got {entry.get('name')!r}"
            )
        if chamber.control != "pressure" or chamber.radius_m is None:
            raise DefectsError(
                f"{where} ({chamber.name!r}): as-built chambers are emulated for pressure-controlled cast cavities "
                f"(angle_deg, offset_m, radius_m), not a {chamber.control}-controlled "
                f"{'mesh surface' if chamber.radius_m is None else 'cavity'}"
            )
        lim_o, lim_a, lim_r = CHAMBER_OFFSET_ERROR_LIMIT_M, CHAMBER_ANGLE_ERROR_LIMIT_DEG, CHAMBER_RADIUS_ERROR_LIMIT_M
        radius_error = ranged(entry, "radius_error_m", where, -lim_r, lim_r, " m")
        if chamber.radius_m + radius_error <= 0:
            raise DefectsError(
                f"field '{where}.radius_error_m' ({radius_error} m) closes the cavity (radius_m {chamber.radius_m} m)"
            )
        offset_error = ranged(entry, "offset_error_m", where, -lim_o, lim_o, " m")
        if chamber.offset_m + offset_error < 0:
            raise DefectsError(
                f"field '{where}.offset_error_m' ({offset_error} m) puts the cavity's axis past the body's axis "
                f"(offset_m {chamber.offset_m} m)"
            )
        full_scale = REGULATOR_OFFSET_LIMIT_FS * chamber.bounds[1]
        out.append(
            ChamberDefects(
                chamber.name,
                offset_error_m=offset_error,
                angle_error_deg=ranged(entry, "angle_error_deg", where, -lim_a, lim_a, " deg"),
                radius_error_m=radius_error,
                stiffness=ranged(entry, "stiffness", where, *CHAMBER_STIFFNESS_RANGE, ""),
                regulator_tau_s=ranged(entry, "regulator_tau_s", where, *REGULATOR_TAU_RANGE_S, " s"),
                regulator_dead_time_s=ranged(entry, "regulator_dead_time_s", where, *REGULATOR_DEAD_TIME_RANGE_S, " s"),
                regulator_gain=ranged(entry, "regulator_gain", where, *REGULATOR_GAIN_RANGE, ""),
                regulator_offset_pa=ranged(entry, "regulator_offset_pa", where, -full_scale, full_scale, " Pa"),
            )
        )
    return tuple(out)


def _motors(data: dict, robot: RobotDescription) -> dict:
    """``[motors]``: required for a cable robot; a robot without cables has none (no ticks,
    no speed limit) unless the file gives the table."""
    if robot.n_cables == 0 and "motors" not in data:
        return {"ticks_per_rev": 0, "profile_velocity_rad_s": math.inf}
    motors = _table(data, "motors")
    return {
        "ticks_per_rev": num(motors, "ticks_per_rev", "motors", lo=0, integer=True),
        "profile_velocity_rad_s": num(motors, "profile_velocity_rad_s", "motors", lo=0.0, lo_open=True),
    }


def _material_law(mat: dict) -> dict:
    law = mat.get("law", "neo-hookean")
    if law not in LAWS:
        raise DefectsError(f"field 'material.law' must be one of {', '.join(map(repr, LAWS))}, got {law!r}")
    if law != "hyperfoam":
        extra = [k for k in HYPERFOAM_FIELDS if k in mat]
        if extra:
            raise DefectsError(f"field 'material.{extra[0]}' applies only with law = \"hyperfoam\" (law is {law!r})")
        return {"law": law}
    for k in HYPERFOAM_FIELDS:
        if k not in mat:
            needs = ", ".join(HYPERFOAM_FIELDS)
            raise DefectsError(f"missing field 'material.{k}' (law = \"hyperfoam\" needs {needs})")
    a_lim = HYPERFOAM_ALPHA_LIMIT
    alpha = ranged(mat, "hyperfoam_alpha", "material", -a_lim, a_lim, "")
    if alpha == 0:
        raise DefectsError(f"field 'material.hyperfoam_alpha' must be nonzero, in [-{a_lim:g}, {a_lim:g}], got 0")
    return {
        "law": law,
        "hyperfoam_mu_pa": ranged(mat, "hyperfoam_mu_pa", "material", 0.0, math.inf, " Pa", lo_open=True, hi_open=True),
        "hyperfoam_alpha": alpha,
        "hyperfoam_beta": ranged(mat, "hyperfoam_beta", "material", 0.0, HYPERFOAM_BETA_LIMIT, "", hi_open=True),
    }


def _lag(data: dict) -> dict:
    lag = _table(data, "lag")
    tau_fast = num(lag, "tau_fast_s", "lag", lo=0.0, lo_open=True)
    tau_slow = num(lag, "tau_slow_s", "lag", lo=0.0, lo_open=True)
    if tau_slow < tau_fast:
        raise DefectsError(f"field 'lag.tau_slow_s' ({tau_slow}) must be >= 'lag.tau_fast_s' ({tau_fast})")
    out = dict(tau_fast_s=tau_fast, tau_slow_s=tau_slow, slow_fraction=num(lag, "slow_fraction", "lag", lo=0.0, hi=1.0))
    if _together(lag, ("creep_fraction", "creep_tau_s"), "lag"):
        creep = ranged(lag, "creep_fraction", "lag", 0.0, 1.0, "", hi_open=True)
        if out["slow_fraction"] + creep >= 1.0:
            raise DefectsError(
                f"field 'lag.creep_fraction' ({creep}) plus 'lag.slow_fraction' ({out['slow_fraction']}) "
                "must be < 1 (the fast mode keeps a share)"
            )
        out.update(
            creep_fraction=creep, creep_tau_s=ranged(lag, "creep_tau_s", "lag", tau_slow, CREEP_TAU_LIMIT_S, " s")
        )
    return out


def _mount_and_frame(data: dict, mocap: dict) -> dict:
    out = {}
    if "mount" in data:
        mount = _table(data, "mount")
        _together(mount, ("tilt_deg", "tilt_axis"), "mount")
        out.update(
            tilt_deg=ranged(mount, "tilt_deg", "mount", *TILT_RANGE_DEG, " deg"),
            tilt_axis_W=vec3(mount, "tilt_axis", "mount", unit=True),
        )
    if _together(mocap, ("frame_rotation_deg", "frame_rotation_axis"), "mocap"):
        out.update(
            frame_rotation_deg=ranged(mocap, "frame_rotation_deg", "mocap", *FRAME_ROTATION_RANGE_DEG, " deg"),
            frame_rotation_axis_W=vec3(mocap, "frame_rotation_axis", "mocap", unit=True),
        )
    if "frame_offset_m" in mocap:
        out["frame_offset_m"] = vec3(mocap, "frame_offset_m", "mocap", norm_limit=FRAME_OFFSET_LIMIT_M)
    return out


def parse_defects(data: dict, robot: RobotDescription, path: str | None = None) -> Defects:
    """Validate a parsed defects TOML document against ``robot`` and build :class:`Defects`.

    Parameters
    ----------
    data : dict
        The parsed TOML document.
    robot : RobotDescription
        The robot the document must fit (name, cables, body size).
    path : str or None
        Where the document came from, recorded in the result.

    Returns
    -------
    Defects
        The validated defects (DefectsError naming the field otherwise).
    """
    check_fields(data, DEFECTS_FIELDS[""], "", DefectsError)
    if data.get("format_version") != FORMAT_VERSION:
        raise DefectsError(f"field 'format_version' must be {FORMAT_VERSION}, got {data.get('format_version')!r}")
    if data.get("robot") != robot.name:
        raise DefectsError(f"field 'robot' is {data.get('robot')!r} but the robot is {robot.name!r}")
    mat = _table(data, "material")
    softness = num(mat, "softness", "material", lo=0.0, lo_open=True)
    gradient = num(mat, "gradient", "material", lo=0.0, hi=1.0)
    direction = vec3(mat, "gradient_direction", "material")
    if abs(direction[0]) > 1e-12 or np.linalg.norm(direction) == 0:
        raise DefectsError(
            "field 'material.gradient_direction' must be a nonzero direction across the "
            f"section (x component 0: the body axis is +x), got {direction.tolist()}"
        )
    law = _material_law(mat)
    cables = _cables(data, robot)
    lag = _lag(data)
    motors, mocap = _motors(data, robot), _table(data, "mocap")
    chambers = _chambers(data, robot)
    emulator = check_fields(data.get("emulator", {}), DEFECTS_FIELDS["emulator"], "emulator", DefectsError)
    mesh = {
        k: (num(emulator, k, "emulator", lo=1, integer=True) if k in emulator else None) for k in ("n_rings", "n_axial")
    }
    return Defects(
        robot=robot.name,
        softness=softness,
        gradient=gradient,
        gradient_direction_W=direction / np.linalg.norm(direction),
        cables=cables,
        **lag,
        **motors,
        frame_rate_hz=num(mocap, "frame_rate_hz", "mocap", lo=0.0, lo_open=True),
        noise_sigma_m=num(mocap, "noise_sigma_m", "mocap", lo=0.0),
        dropout_rate_hz=num(mocap, "dropout_rate_hz", "mocap", lo=0.0),
        dropout_max_frames=num(mocap, "dropout_max_frames", "mocap", lo=1, integer=True),
        **_mount_and_frame(data, mocap),
        n_rings=mesh["n_rings"],
        n_axial=mesh["n_axial"],
        path=path,
        source=data,
        **law,
        chambers=chambers,
    )
