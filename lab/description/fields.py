"""Reading the fields of a parsed TOML table: names checked, values typed, errors naming them.

:func:`check_fields` refuses a misspelt field (naming the closest valid one) and is shared by
every TOML reader of the package (robots, defects, hardware configs). The small readers
below return a field as a finite float, int or string, a 3-vector or an array, and raise
:class:`~lab.description.robot.DescriptionError` naming ``table.field`` otherwise.
"""

from __future__ import annotations

import difflib
import math

import numpy as np

from lab.description.robot import DescriptionError

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
        "markers",
        "safety",
        "chambers",
    },
    "body": {"shape", "length_m", "radius_m", "profile_m", "mesh_file", "mesh_unit", "clamp", "clamp_group"},
    "material": {
        "model",
        "youngs_modulus_pa",
        "poisson_ratio",
        "density_kg_m3",
        "stiffness_gradient",
        "yeoh_c10_pa",
        "yeoh_c20_pa",
        "yeoh_c30_pa",
        "bulk_modulus_pa",
    },
    "mounting": {"gravity_m_s2"},
    "mesh": {"n_rings", "n_axial", "size_m", "order"},
    "actuation": {"spool_radius_m", "u_max_rad", "cable_stiffness_n_m", "slack_smoothing_m"},
    "cables": {
        "name",
        "angle_deg",
        "offset_m",
        "stations_m",
        "via_points_m",
        "anchor_m",
        "slack_m",
        "control",
        "tension_max_n",
    },
    "chambers": {
        "name",
        "control",
        "pressure_max_pa",
        "pressure_min_pa",
        "volume_max_m3",
        "volume_min_m3",
        "fluid_bulk_modulus_pa",
        "angle_deg",
        "offset_m",
        "radius_m",
        "start_m",
        "end_m",
        "surface_group",
    },
    "tip_marker": {"position_m"},
    "markers": {"name", "position_m"},
    "safety": {"limits"},
    "safety.limits": {"cables", "max_sum_over_u_max"},
}


def check_fields(table, allowed, where: str, error: type[Exception] = None) -> dict:
    """Refuse a table that is not a table, or that has a field not in ``allowed``.

    A misspelt field would otherwise be ignored silently; the error names the closest
    valid name. Shared by the robot, defects and hardware-config readers.

    Parameters
    ----------
    table : object
        The parsed TOML table (a dict, or anything else to refuse).
    allowed : set of str
        The valid field names.
    where : str
        The table's name (``"material"``, ``"cables[1]"``; ``""`` for the top level).
    error : type, optional
        The exception to raise; default :class:`DescriptionError`.

    Returns
    -------
    dict
        ``table`` itself.
    """
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


def get(table: dict, key: str, where: str, kind=float, positive: bool = False):
    """The field ``where.key`` as a finite float, an int or a str (``kind``), checked."""
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


def vec3(table: dict, key: str, where: str) -> np.ndarray:
    """The field ``where.key`` as a finite 3-vector."""
    if key not in table:
        raise DescriptionError(f"missing field '{where}.{key}'")
    v = np.asarray(table[key], dtype=object)
    if v.shape != (3,) or not all(isinstance(c, (int, float)) and not isinstance(c, bool) for c in v):
        raise DescriptionError(f"field '{where}.{key}' must be a list of 3 numbers, got {table[key]!r}")
    v = v.astype(float)
    if not np.all(np.isfinite(v)):
        raise DescriptionError(f"field '{where}.{key}' must be finite, got {table[key]!r}")
    return v


def table(data: dict, key: str, required: bool = True) -> dict:
    """The table ``[key]`` with its fields checked; ``{}`` when absent and not ``required``."""
    t = data.get(key)
    if t is None:
        if not required:
            return {}
        raise DescriptionError(f"missing table [{key}]")
    return check_fields(t, ROBOT_FIELDS[key], key)


def points(entry: dict, key: str, where: str) -> np.ndarray:
    """The field ``where.key`` as a finite float array (any shape; the caller checks it)."""
    try:
        out = np.asarray(entry[key], dtype=float)
    except (TypeError, ValueError):
        raise DescriptionError(f"field '{where}.{key}' must hold numbers, got {entry[key]!r}") from None
    if not np.all(np.isfinite(out)):
        raise DescriptionError(f"field '{where}.{key}' must be finite, got {entry[key]!r}")
    return out


def refuse_unused(entry: dict, keys, where: str, why: str) -> None:
    """Refuse fields that the chosen mode does not use (a typo there would be silently ignored)."""
    for key in keys:
        if key in entry:
            raise DescriptionError(f"field '{where}.{key}' is not used {why}; remove it")
