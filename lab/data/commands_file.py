"""The commands a lab actually sent, read from a CSV file (``simulate --commands U.csv``).

One row per command, in the order they were sent; one column per input of the robot,
named ``u0..u{m-1}`` or after the robot's cables (``[[cables]] name``), in any column order:
:func:`read_commands` maps them to the robot's input order. A column that names no input, an
input given twice (two columns for one input, by either name) or missing, a NaN or
non-numeric value, or a command the robot refuses (:meth:`RobotDescription.check_command`:
out of an input's range, or against a safety rule) is an InputError naming the file, the
line and the column -- and, for a column whose values all fit its input's range in another
unit (degrees for radians, mN for N), that unit. The file is read strictly (:func:`lab.data.csv_table.read_table`).
"""

from __future__ import annotations

import numpy as np

from lab.data.csv_table import NAN, NON_NUMERIC, read_table
from lab.data.plausibility import largest, unit_hint
from lab.description import RobotDescription
from lab.errors import InputError

__all__ = ["read_commands", "input_names"]


def input_names(robot: RobotDescription) -> dict[str, int]:
    """The column names that a commands file may give each input.

    Parameters
    ----------
    robot : RobotDescription
        The robot.

    Returns
    -------
    dict
        Name -> input index: ``u0..u{m-1}`` and each cable's name.
    """
    names = {f"u{i}": i for i in range(robot.n_inputs)}
    for i, name in enumerate(robot.input_names):
        names.setdefault(name, i)
    return names


def read_commands(path, robot: RobotDescription, what: str = "--commands") -> tuple[np.ndarray, dict]:
    """The commands of the CSV file ``path``, in the file's row order, in the robot's input order.

    Parameters
    ----------
    path : str or pathlib.Path
        The commands file.
    robot : RobotDescription
        The robot they were sent to.
    what : str
        How errors name the file.

    Returns
    -------
    u : numpy.ndarray
        The commands (N, m), each input in its unit (``robot.input_units``: rad, N).
    source : dict
        The file's ``path``, ``sha256``, the ``columns`` read (in the robot's input order)
        and ``n`` rows.
    """
    table = read_table(path, what=what)
    names = input_names(robot)
    units = robot.input_units
    column_of = [None] * robot.n_inputs
    for c, name in enumerate(table.header):
        if name not in names:
            expected = ", ".join(f"u{i} or {robot.input_names[i]!r}" for i in range(robot.n_inputs))
            raise InputError(
                f"{path}: column {c + 1} ({name!r}) names no input of {robot.name}; the columns are its "
                f"inputs, each once: {expected}"
            )
        i = names[name]
        if column_of[i] is not None:
            raise InputError(
                f"{path}: columns {table.header[column_of[i]]!r} and {name!r} both give input u{i} "
                f"(input {robot.input_names[i]!r}): give each input once"
            )
        column_of[i] = c
    missing = [i for i, c in enumerate(column_of) if c is None]
    if missing:
        shown = ", ".join(f"u{i} ({robot.input_names[i]!r}, {units[i]})" for i in missing)
        raise InputError(
            f"{path}: no column for input(s) {shown} of {robot.name}; its columns are: {', '.join(table.header)}"
        )
    header = [table.header[c] for c in column_of]
    u, kind = table.numbers(header, what)
    for r, line in enumerate(table.lines):
        bad = np.flatnonzero(kind[r])
        if len(bad):
            j = int(bad[0])
            text = table.rows[r][column_of[j]]
            why = "not a number" if kind[r, j] == NON_NUMERIC else ("empty" if not text.strip() else "NaN or infinite")
            assert kind[r, j] in (NAN, NON_NUMERIC)
            raise InputError(f"{path}: line {line}, column {header[j]!r}: {text!r} is {why}")
        try:
            robot.check_command(u[r])
        except InputError as err:
            out = [j for j in range(robot.n_inputs) if not robot.u_lower[j] <= u[r, j] <= robot.u_upper[j]]
            col = f", column {header[out[0]]!r}" if out else ""
            raise InputError(f"{path}: line {line}{col}: {err}{_unit_advice(u, robot, out)}") from None
    return u, {"path": str(path), "sha256": table.sha256, "columns": header, "n": len(u)}


def _unit_advice(u: np.ndarray, robot: RobotDescription, out: list) -> str:
    """Words for a column out of its input's range whose values all fit that range in another
    unit (``deg`` read as ``rad``, ``mN`` as ``N``, ...): a commands file is in the robot's units."""
    if not out:
        return ""
    j = out[0]
    unit, low, high = robot.input_units[j], robot.u_lower[j], robot.u_upper[j]
    fits = unit_hint(u[:, j], unit, unit, low, high)
    if fits is None:
        return ""
    return (
        f"; its values up to {largest(u[:, j]):g} look like {fits}, not {unit}: a commands file gives each "
        f"input in its unit ({unit} for input u{j}); convert them"
    )
