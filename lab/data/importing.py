"""External measurements -> (u, y) rows in metres -> a lab dataset (``python -m lab import-data``).

A real robot's data rarely arrive in this project's format: inputs and observations sit in
separate files (paired row by row, or on an ID column), positions in millimetres, columns
named after the lab that measured them. :func:`read_measurements` reads them as an
:class:`lab.data.import_spec.ImportSpec` says -- one CSV per group of rows holding both
inputs and outputs, or ``FILE i`` (the ``--u`` columns) paired with ``OBS i`` (the ``--y``
columns) -- and returns the inputs (N, m), the positions in metres (N, d) for any d >= 1 (a
study may fit all nine ASL disk coordinates), where measurement sequences start (each file
or pair starts one; ``--group COL`` starts one where COL's value changes), and per file or
pair a provenance record: the sources with their SHA-256 and the columns taken, the rows
dropped and why. Rows keep the inputs' measurement order. :func:`import_dataset` writes the
tip (d = 3) as a lab dataset with the sidecar keys of docs/import-data.md. Bad input is an
InputError naming the file, line and column; a NaN or non-numeric value is one unless
``--drop-bad-rows`` drops the row and counts it.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from decimal import MAX_EMAX, MIN_EMIN, Context
from pathlib import Path

import numpy as np

from lab.data.csv_table import NON_NUMERIC, CsvTable, read_table
from lab.data.dataset import write_dataset
from lab.data.import_spec import KINDS, U_UNITS, Y_UNITS, ImportSpec, markers_of_columns
from lab.data.plausibility import check_columns
from lab.errors import FieldError, InputError

__all__ = ["Measurements", "ImportResult", "read_measurements", "import_dataset"]

#: An ID that is a number written in ASCII decimal (compared by value, exactly).
_DECIMAL = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?", re.ASCII)


@dataclass(frozen=True)
class Measurements:
    """Imported rows.

    Attributes
    ----------
    u : numpy.ndarray
        Inputs (N, m), in the spec's ``u_unit`` converted to SI (:data:`U_UNITS`), or as read
        for a free-text unit.
    y_m : numpy.ndarray
        Positions (N, d), m.
    sequence_starts : list of int
        First row of each sequence, from 0.
    row_groups : list of dict
        One per file or pair: start, stop, sources, dropped, join.
    notes : list of str
        The rules applied.
    """

    u: np.ndarray
    y_m: np.ndarray
    sequence_starts: list[int]
    row_groups: list[dict]
    notes: list[str]

    def dropped(self) -> dict:
        """Rows dropped over all groups, per reason.

        Returns
        -------
        dict
            Reason (``nan``, ``non_numeric``, ``unmatched_id``) -> number of rows.
        """
        return _total_dropped(self.row_groups)


def _total_dropped(row_groups) -> dict:
    total = {"nan": 0, "non_numeric": 0, "unmatched_id": 0}
    for g in row_groups:
        for k, v in g["dropped"].items():
            total[k] += v
    return total


@dataclass(frozen=True)
class ImportResult:
    """What :func:`import_dataset` wrote: the rows, sequences and groups, drops and notes.

    Attributes
    ----------
    out : str
        The dataset written.
    n_rows, n_sequences, n_groups : int
        Its rows, measurement sequences and row groups (files or pairs).
    dropped : dict
        Rows dropped, per reason.
    notes : list of str
        The rules applied.
    """

    out: str
    n_rows: int
    n_sequences: int
    n_groups: int
    dropped: dict
    notes: list[str]


def _id_key(text: str) -> str:
    """An ID compared by its exact value: "7", "7.0", "7e0" and " 7" are the same row, and
    "90071992547409930" and "...931" are not (a float would make them equal); other text as is."""
    text = text.strip()
    if not _DECIMAL.fullmatch(text):
        return text
    exact = Context(prec=len(text), Emax=MAX_EMAX, Emin=MIN_EMIN)  # as many digits as the text has: exact
    value = exact.create_decimal(text)
    return "0" if value.is_zero() else str(value.normalize(exact))


def _ids(table: CsvTable, column: str) -> list[str]:
    keys, first = [], {}
    for text, line in zip(table.strings(column, "ImportSpec.id"), table.lines):
        if not text:
            raise InputError(f"{table.path}: line {line}, column {column!r} (ImportSpec.id): empty ID")
        key = _id_key(text)
        if key in first:
            raise InputError(
                f"{table.path}: the ID {text!r} on line {line} repeats the ID {first[key][1]!r} of line "
                f"{first[key][0]} (column {column!r}, ImportSpec.id): IDs must be unique to pair rows"
            )
        first[key] = (line, text)
        keys.append(key)
    return keys


def _pair(spec: ImportSpec, inputs: CsvTable, obs: CsvTable, notes: list) -> tuple[np.ndarray, np.ndarray, int, str]:
    """Row indices into ``inputs`` and ``obs`` that pair, in the inputs' order; the number of
    rows dropped for an unmatched ID; the join used ("id" or "row")."""
    phantom = [t for t in (inputs, obs) if spec.id is not None and t.phantom == spec.id]
    if spec.id is None or phantom:
        if phantom:
            notes.append(
                f"{phantom[0].path}: the header names {spec.id!r} but no row has a value for it (phantom-ID rule): "
                f"paired with {(obs if phantom[0] is inputs else inputs).path} by row order"
            )
        if len(inputs.rows) != len(obs.rows):
            raise InputError(
                f"{inputs.path} has {len(inputs.rows)} rows, its observations file {obs.path} has {len(obs.rows)}: "
                "pairing row by row needs equal counts (pair on an ID column both have with ImportSpec.id COL)"
            )
        rows = np.arange(len(inputs.rows))
        return rows, rows, 0, "row"
    ids_in, ids_obs = _ids(inputs, spec.id), _ids(obs, spec.id)
    where = {key: j for j, key in enumerate(ids_obs)}
    rows_in = np.array([i for i, key in enumerate(ids_in) if key in where], dtype=int)
    rows_obs = np.array([where[ids_in[i]] for i in rows_in], dtype=int)
    unmatched = len(ids_in) - len(rows_in) + len(ids_obs) - len(rows_obs)
    return rows_in, rows_obs, unmatched, "id"


def _bad_cell(spec, tables, kinds, rows, r) -> str:
    """The message for the first bad cell of paired row ``r``."""
    for table, names, flag, kind, index in zip(tables, (spec.u, spec.y), ("ImportSpec.u", "ImportSpec.y"), kinds, rows):
        for c, name in enumerate(names):
            k = kind[index[r], c]
            if k:
                text = table.rows[index[r]][table.index(name, flag)]
                what = "not a number" if k == NON_NUMERIC else ("empty" if not text.strip() else "NaN or infinite")
                if k == NON_NUMERIC and (not text.isascii() or "_" in text):
                    what += " (a number in a CSV file is ASCII digits, without '_' separators)"
                return (
                    f"{table.path}: line {table.lines[index[r]]}, column {name!r} ({flag}): {text!r} is {what}; "
                    "set ImportSpec.drop_bad_rows to drop such rows (they are counted in the sidecar)"
                )
    raise AssertionError("no bad cell in a bad row")


def _group(spec: ImportSpec, path, obs_path, notes: list) -> tuple[np.ndarray, np.ndarray, list[int], dict]:
    """One file (``obs_path`` None) or pair: inputs, positions (metres), sequence starts
    within it, and its row-group record (without start/stop)."""
    inputs = read_table(path, id_column=spec.id if obs_path else None, what="FILE")
    obs = inputs if obs_path is None else read_table(obs_path, id_column=spec.id, what="observations file")
    for t in {id(inputs): inputs, id(obs): obs}.values():
        if t.phantom and not (spec.id is not None and obs is not inputs):
            notes.append(
                f"{t.path}: the header names {t.phantom!r} but no row has a value for it: read as lacking that "
                "column (phantom-ID rule)"
            )
    u_all, ku = inputs.numbers(spec.u, "ImportSpec.u")
    y_all, ky = obs.numbers(spec.y, "ImportSpec.y")
    if obs is inputs:
        rows_in = rows_obs = np.arange(len(inputs.rows))
        unmatched, join = 0, "one file"
    else:
        rows_in, rows_obs, unmatched, join = _pair(spec, inputs, obs, notes)
    kind = np.concatenate([ku[rows_in], ky[rows_obs]], axis=1)
    bad = kind.any(axis=1)
    if bad.any() and not spec.drop_bad_rows:
        raise InputError(_bad_cell(spec, (inputs, obs), (ku, ky), (rows_in, rows_obs), int(np.argmax(bad))))
    non_numeric = (kind == NON_NUMERIC).any(axis=1)
    dropped = {"nan": int((bad & ~non_numeric).sum()), "non_numeric": int(non_numeric.sum()), "unmatched_id": unmatched}
    keep = ~bad
    y_read = y_all[rows_obs[keep]]
    u, y_m = _to_si(spec, inputs, rows_in[keep], u_all[rows_in[keep]]), y_read * spec.y_scale
    units = ([spec.y_unit] * len(spec.y), ["m"] * len(spec.y))
    check_columns(obs, rows_obs[keep], spec.y, "ImportSpec.y", (y_read, y_m), units, ("ImportSpec.y_unit", Y_UNITS))
    starts = [0] if len(u) else []
    if spec.group is not None:
        table, rows = (inputs, rows_in) if inputs.has(spec.group) or not obs.has(spec.group) else (obs, rows_obs)
        values = np.array(table.strings(spec.group, "ImportSpec.group"), dtype=object)[rows[keep]]
        starts += [int(k) for k in np.flatnonzero(values[1:] != values[:-1]) + 1]
    sources = [{"path": str(path), "sha256": inputs.sha256, "columns": list(spec.u if obs_path else spec.u + spec.y)}]
    if obs_path is not None:
        sources.append({"path": str(obs_path), "sha256": obs.sha256, "columns": list(spec.y)})
    for s, t in zip(sources, (inputs, obs)):
        s["rows"] = len(t.rows)
        if join == "id":
            s["columns"].append(spec.id)
        if spec.group is not None and t.has(spec.group) and spec.group not in s["columns"]:
            s["columns"].append(spec.group)
    return u, y_m, starts, {"sources": sources, "join": join, "dropped": dropped}


def _to_si(spec: ImportSpec, table: CsvTable, rows: np.ndarray, u: np.ndarray) -> np.ndarray:
    """The inputs (N, m) converted to SI per :data:`U_UNITS` (free text: as read), each
    checked for plausibility (:func:`lab.data.plausibility.check_columns`)."""
    units = spec.u_units
    if units is None:
        return u
    u_si = u * np.array([U_UNITS[unit][1] for unit in units])
    si = [U_UNITS[unit][0] for unit in units]
    check_columns(table, rows, spec.u, "ImportSpec.u", (u, u_si), (units, si), ("ImportSpec.u_unit", U_UNITS))
    return u_si


def _robot_check(spec: ImportSpec, robot) -> None:
    """Refuse data whose inputs do not fit ``robot``: their number, or their unit's kind."""
    if len(spec.u) != robot.n_inputs:
        raise InputError(
            f"ImportSpec.u names {len(spec.u)} input column(s) but the robot {robot.name} (ImportSpec.robot) "
            f"has {robot.n_inputs} inputs ({', '.join(robot.input_names)})"
        )
    units = spec.u_units
    for j, want in enumerate(robot.input_units):
        got = U_UNITS[units[j]][0] if units is not None else None
        if got != want:
            given = units[j] if units is not None else spec.u_unit
            what = KINDS.get(got, "not a unit this package converts")
            raise InputError(
                f"ImportSpec.u_unit {given!r} is {what}, but input u{j} (column {spec.u[j]!r}) of {robot.name} "
                f"(input {robot.input_names[j]!r}) is {KINDS[want]} in {want}: give its unit "
                f"({', '.join(u for u, (si, _) in U_UNITS.items() if si == want)})"
            )


def _marker_names(spec: ImportSpec, robot) -> tuple[str, ...]:
    """The names of the markers of ``spec.y`` (the tip first); InputError when they cannot be told."""
    k = len(spec.y) // 3
    names = None
    if len(spec.y) % 3 == 0:
        if spec.markers is not None:
            names = ("tip", *spec.markers)
        elif k == 1:
            names = ("tip",)
        elif robot is not None and len(robot.marker_names) == k:
            names = tuple(robot.marker_names)
        else:
            names = markers_of_columns(spec.y)
    if names is None:
        raise InputError(
            f"ImportSpec.y names {len(spec.y)} column(s) ({','.join(spec.y)}): a lab dataset holds the tip's x,y,z "
            "and then each marker's; give exactly 3 (the tip's, e.g. x3,y3,z3), or 3 per marker with the markers "
            "after the tip named (ImportSpec.markers, a robot with as many markers, ImportSpec.robot, or columns "
            "NAME_x,NAME_y,NAME_z); to read any columns, use lab.data.importing.read_measurements"
        )
    if robot is not None and tuple(names) != tuple(robot.marker_names):
        raise InputError(
            f"the markers of ImportSpec.y ({', '.join(names)}) are not those of {robot.name} (ImportSpec.robot): "
            f"{', '.join(robot.marker_names)}"
        )
    return tuple(names)


def read_measurements(spec: ImportSpec, files, observations=()) -> Measurements:
    """Read ``files`` (each with the ``--u`` and ``--y`` columns), or ``files[i]`` (the
    ``--u`` columns) paired with ``observations[i]`` (the ``--y`` columns), as ``spec`` says.

    InputError for bad input (naming the file, line and column), unequal numbers of files
    and observation files, ``--id`` without observation files, or no rows left.

    Parameters
    ----------
    spec : ImportSpec
        Which columns, units, groups and IDs.
    files : iterable of str or pathlib.Path
        The input CSV files.
    observations : iterable of str or pathlib.Path
        Observation files, one per input file, or none.

    Returns
    -------
    Measurements
        Inputs (N, m), positions (N, d) in metres for any number d of ``--y`` columns,
        sequence starts and per-group provenance.
    """
    files, observations = list(files), list(observations)
    if not files:
        raise InputError("no input FILE given")
    if observations and len(observations) != len(files):
        raise InputError(
            f"{len(files)} FILEs but {len(observations)} observations files: FILE i pairs with OBS i, "
            "give as many of each"
        )
    if spec.id is not None and not observations:
        raise FieldError(
            "ImportSpec.id is not used without observations files: it pairs the rows of an input and an OBS file"
        )
    us, ys, starts, groups, notes = [], [], [], [], []
    n = 0
    for i, path in enumerate(files):
        u, y_m, s, group = _group(spec, path, observations[i] if observations else None, notes)
        us.append(u)
        ys.append(y_m)
        starts += [n + k for k in s]
        groups.append({"start": n, "stop": n + len(u), **group})
        n += len(u)
    if n == 0:
        dropped = _total_dropped(groups)
        raise InputError(
            f"no rows left to import from {len(files)} file(s): dropped {dropped['nan']} with NaN or empty values, "
            f"{dropped['non_numeric']} non-numeric, {dropped['unmatched_id']} with unmatched IDs"
        )
    return Measurements(np.concatenate(us), np.concatenate(ys), starts, groups, notes)


def import_dataset(spec: ImportSpec, files, out, *, observations=(), command: str | None = None) -> ImportResult:
    """Import ``files`` (and ``observations``) as :func:`read_measurements` does and write
    the lab dataset ``out`` (u (N, m) in ``--u-unit``, SI for a unit of
    :data:`~lab.data.import_spec.U_UNITS`; every marker (N, 3K) metres, the tip first) with its sidecar:
    ``sequence_starts``, ``robot`` (kind "measured", input limits from the data), ``units``,
    ``licence``, ``source``, ``row_groups``, ``notes``, ``import`` and ``command``. ``--y``
    names the tip's 3 columns, then 3 per marker (named by ``--markers``, the ``--robot``'s
    markers or columns ``NAME_x, NAME_y, NAME_z``). With ``--robot``, the inputs' number and
    unit must be its inputs'.

    Parameters
    ----------
    spec : ImportSpec
        Which columns, units, groups and IDs.
    files : iterable of str or pathlib.Path
        The input CSV files.
    out : str or pathlib.Path
        The dataset CSV to write.
    observations : iterable of str or pathlib.Path
        Observation files, one per input file, or none.
    command : str, optional
        The command line, recorded in the sidecar.

    Returns
    -------
    ImportResult
        What was written.
    """
    robot = None
    if spec.robot is not None:
        from lab.description import load_robot

        robot = load_robot(spec.robot)
        _robot_check(spec, robot)
    names = _marker_names(spec, robot)
    m = read_measurements(spec, files, observations)
    units = spec.u_units
    si = [U_UNITS[u][0] for u in units] if units is not None else [spec.u_unit] * len(spec.u)
    u_unit = si[0] if len(set(si)) == 1 else si
    record = {
        "name": spec.name or (robot.name if robot is not None else Path(out).stem),
        "kind": "measured",
        "n_motors": len(spec.u),
        "u_min": m.u.min(axis=0).tolist(),
        "u_max": m.u.max(axis=0).tolist(),
        "u_unit": u_unit,
        "y_unit": "m",
    }
    if robot is not None:
        record["description"] = {"name": robot.name, "sha256": robot.sha256}
    settings = {"u_columns": list(spec.u), "y_columns": list(spec.y), "y_unit_read": spec.y_unit}
    if units is not None and list(units) != si:
        settings["u_unit_read"] = spec.u_unit
    settings |= {"id": spec.id, "group": spec.group, "drop_bad_rows": spec.drop_bad_rows}
    meta = {
        "sequence_starts": m.sequence_starts,
        "robot": record,
        "units": {"u": u_unit, "xyz": "m"},
        "licence": spec.licence,
        "source": spec.source,
        "row_groups": m.row_groups,
        "notes": m.notes,
        "import": settings,
        "command": command,
    }
    write_dataset(out, m.u, m.y_m, meta, markers=names, units=si)
    return ImportResult(str(out), len(m.u), len(m.sequence_starts), len(m.row_groups), m.dropped(), m.notes)
