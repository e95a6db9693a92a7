"""Numbers that cannot be in the unit they are said to be in, and the unit they look like.

A file of tip positions in millimetres read as metres puts the tip 100 m away; spool angles
in degrees read as radians wind a cable tens of turns. Neither is an error of format, so
each value read in a known SI unit is checked against the range a soft robot's lab can
produce (:data:`PLAUSIBLE`, from the ``MAX_*`` bounds below) -- or against a robot's own
input range -- and a value outside it is refused with the smaller unit in which every value
of its column would fit (:data:`UNITS_OF`: ``mm`` for metres, ``deg`` for radians, ...).
:func:`first_implausible` finds the first such value, :func:`unit_hint` the unit that fits;
:func:`check_columns` checks a table's columns with both.
"""

from __future__ import annotations

import math

import numpy as np

from lab.errors import InputError

__all__ = [
    "MAX_ABS_POSITION_M",
    "MAX_ABS_ANGLE_RAD",
    "MAX_TENSION_N",
    "MAX_PRESSURE_PA",
    "MAX_VOLUME_M3",
    "PLAUSIBLE",
    "UNITS_OF",
    "first_implausible",
    "unit_hint",
    "largest",
    "check_columns",
]

#: Largest plausible |coordinate| of an imported position, m (a motion-capture room's extent;
#: a file in mm or cm read as metres lies far beyond it).
MAX_ABS_POSITION_M = 5.0
#: Largest plausible |input angle|, rad: ten turns of a spool (degrees read as radians exceed it
#: from 63 degrees of travel up).
MAX_ABS_ANGLE_RAD = 20 * math.pi
#: Largest plausible tendon tension, N (a load cell's offset may read a little below zero).
MAX_TENSION_N = 1e4
#: Largest plausible gauge pressure, Pa (100 bar; no lower than vacuum).
MAX_PRESSURE_PA = 1e7
#: Largest plausible volume pumped in or out, m^3 (10 L).
MAX_VOLUME_M3 = 1e-2

#: The plausible range of a value, per SI unit.
PLAUSIBLE = {
    "m": (-MAX_ABS_POSITION_M, MAX_ABS_POSITION_M),
    "rad": (-MAX_ABS_ANGLE_RAD, MAX_ABS_ANGLE_RAD),
    "N": (-1.0, MAX_TENSION_N),
    "Pa": (-101_325.0, MAX_PRESSURE_PA),
    "m^3": (-MAX_VOLUME_M3, MAX_VOLUME_M3),
}
_KINDS = {"m": "a position", "rad": "an angle", "N": "a tension", "Pa": "a pressure", "m^3": "a volume"}
#: The units a value of each SI unit may have been written in: name -> factor to the SI unit,
#: the likeliest for a too large value first (a tip in mm rather than cm, a pressure in kPa).
UNITS_OF = {
    "m": {"mm": 1e-3, "cm": 1e-2, "m": 1.0},
    "rad": {"deg": math.pi / 180, "rad": 1.0},
    "N": {"mN": 1e-3, "N": 1.0},
    "Pa": {"kPa": 1e3, "Pa": 1.0, "bar": 1e5},
    "m^3": {"mL": 1e-6, "L": 1e-3, "m^3": 1.0},
}


def first_implausible(values: np.ndarray, low: float, high: float) -> int | None:
    """The index of the first value outside ``[low, high]``, or None.

    Parameters
    ----------
    values : numpy.ndarray
        Values (N,) in the unit of ``low`` and ``high``; NaN is skipped.
    low, high : float
        The plausible range.

    Returns
    -------
    int or None
        The row of the first implausible value.
    """
    out = np.flatnonzero((values < low) | (values > high))
    return int(out[0]) if len(out) else None


def unit_hint(values: np.ndarray, unit: str, si: str, low: float, high: float) -> str | None:
    """The unit in which every one of ``values`` would lie in ``[low, high]``, worded.

    Parameters
    ----------
    values : numpy.ndarray
        A column's values (N,) as written, read as ``unit``; NaN is skipped.
    unit : str
        The unit they were read in (a key of ``UNITS_OF[si]``).
    si : str
        Its SI unit (a key of :data:`UNITS_OF`).
    low, high : float
        The plausible (or allowed) range, in ``si``.

    Returns
    -------
    str or None
        ``"mm"`` for values up to 182 read as m; None when no other unit fits.
    """
    values = values[np.isfinite(values)]
    for name, factor in UNITS_OF.get(si, {}).items():
        if name != unit and len(values) and np.all((values * factor >= low) & (values * factor <= high)):
            return name
    return None


def largest(values: np.ndarray) -> float:
    """The value of largest magnitude of ``values`` (N,), NaN skipped (NaN if none), for messages.

    Parameters
    ----------
    values : numpy.ndarray
        Values (N,).

    Returns
    -------
    float
        E.g. -182.0 of (3, -182, 12).
    """
    values = values[np.isfinite(values)]
    return float(values[np.argmax(np.abs(values))]) if len(values) else float("nan")


def check_columns(table, rows, names, flag, values, units, fix) -> None:
    """Refuse the first value of ``table``'s columns ``names`` outside :data:`PLAUSIBLE` for its
    SI unit: InputError naming the file, line and column, and the unit the column looks like.

    Parameters
    ----------
    table : lab.data.csv_table.CsvTable
        The file the values were read from.
    rows : numpy.ndarray
        The row of ``table`` of each value (N,).
    names : sequence of str
        The columns (k).
    flag : str
        The setting that names the columns (e.g. ``ImportSpec.y``).
    values : tuple of numpy.ndarray
        The values as read and in SI units, each (N, k).
    units : tuple of sequence of str
        The unit each column was read in, and its SI unit (k each).
    fix : tuple
        The setting that gives the unit (e.g. ``ImportSpec.y_unit``) and the units it takes.

    Raises
    ------
    lab.errors.InputError
        For an implausible value.
    """
    (read, si_values), (read_units, si_units), (setting, takes) = values, units, fix
    for j, unit in enumerate(si_units):
        low, high = PLAUSIBLE.get(unit, (-np.inf, np.inf))
        r = first_implausible(si_values[:, j], low, high)
        if r is None:
            continue
        text = table.rows[rows[r]][table.index(names[j], flag)].strip()
        fits = unit_hint(read[:, j], read_units[j], unit, low, high)
        advice = f"check {setting}"
        if fits is not None:
            how = f"give {setting} {fits}" if fits in takes else f"convert them to {read_units[j]}"
            advice = f"values up to {largest(read[:, j]):g} look like {fits}, not {read_units[j]}; {how}"
        raise InputError(
            f"{table.path}: line {table.lines[rows[r]]}, column {names[j]!r} ({flag}): {text} {read_units[j]} is not "
            f"plausible for {_KINDS[unit]} (from {low:g} to {high:g} {unit}); {advice}"
        )
