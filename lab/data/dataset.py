"""(u, y) datasets on disk: a plain CSV plus a JSON sidecar with versioned metadata.

``DATA.csv`` has the header ``u0,...,u{m-1},x,y,z`` (the inputs, each in its unit: motor
angles in radians, tensions in newtons; the tip position in metres, frame W), then, for a
robot observed at several markers, ``NAME_x,NAME_y,NAME_z`` per further marker in the robot's
order, and one row per sample, nothing else: the outputs y are (N, 3K), the tip first (a
consumer that needs the tip takes ``y[:, :3]``). ``DATA.csv.json`` holds the metadata (robot
description and hash, mesh, sampler, code version, date, the ``markers`` and each input's
unit, ``input_units``). A tip-only dataset is written exactly as before markers existed.
Both are written atomically (temporary file + rename), so a crash never leaves a
half-written dataset behind. Nothing is pickled.
"""

from __future__ import annotations

import csv
import datetime as _dt
import hashlib
import io
import json
from pathlib import Path

import numpy as np

from lab.errors import InputError
from lab.files import atomic_write_group, code_version, json_default

FORMAT_VERSION = 1


class DatasetError(InputError):
    """A dataset file is missing, corrupt, or from an unsupported format version."""


def output_columns(markers=("tip",)) -> list[str]:
    """The output columns of a dataset observed at ``markers``.

    Parameters
    ----------
    markers : sequence of str
        The marker names, the tip first (its columns are ``x, y, z``).

    Returns
    -------
    list of str
        ``x, y, z``, then ``NAME_x, NAME_y, NAME_z`` per further marker (3K names).
    """
    return ["x", "y", "z"] + [f"{name}_{a}" for name in list(markers)[1:] for a in "xyz"]


def columns(n_motors: int, markers=("tip",)) -> list[str]:
    """The dataset CSV's header.

    Parameters
    ----------
    n_motors : int
        Number of inputs m.
    markers : sequence of str
        The marker names, the tip first (default: the tip only).

    Returns
    -------
    list of str
        ``u0, ..., u{m-1}, x, y, z`` and ``NAME_x, NAME_y, NAME_z`` per further marker.
    """
    return [f"u{i}" for i in range(n_motors)] + output_columns(markers)


def marker_names(metadata: dict) -> tuple[str, ...]:
    """The marker names of a dataset read by :func:`read_dataset`, the tip first.

    Parameters
    ----------
    metadata : dict
        Its metadata (the third value :func:`read_dataset` returns).

    Returns
    -------
    tuple of str
        ``("tip", ...)``: K names for outputs y of shape (N, 3K).
    """
    return tuple(metadata.get("markers") or ("tip",))


def dataset_markers(metadata: dict, y, robot=None, what: str = "the dataset") -> tuple[str, ...]:
    """The markers a dataset's outputs hold, checked against its columns and a robot.

    Parameters
    ----------
    metadata : dict
        Its metadata (:func:`read_dataset` names the markers of its header there).
    y : numpy.ndarray
        Its outputs, shape (N, 3K), m.
    robot : RobotDescription, optional
        The robot the data must fit: every marker must be one of its ``marker_names``.
    what : str
        The dataset, for the messages (e.g. its path).

    Returns
    -------
    tuple of str
        The K marker names in column order, the tip first (DatasetError for a marker the
        robot lacks or a column count that does not fit them).
    """
    names = marker_names(metadata)
    if robot is not None:
        unknown = [k for k in names if k not in robot.marker_names]
        if unknown:
            raise DatasetError(
                f"{what}: marker {unknown[0]!r} is not one of robot {robot.name}'s markers {list(robot.marker_names)}"
            )
    if np.shape(y)[1] != 3 * len(names):
        raise DatasetError(
            f"{what}: {np.shape(y)[1]} output columns, but its markers {list(names)} need {3 * len(names)}"
        )
    return names


def input_units(metadata: dict, n_inputs: int) -> tuple[str, ...]:
    """The unit of each input of a dataset read by :func:`read_dataset`.

    Parameters
    ----------
    metadata : dict
        Its metadata.
    n_inputs : int
        Number of inputs m.

    Returns
    -------
    tuple of str
        m units: the sidecar's ``input_units``, else its ``units.u`` (one for all, or a list),
        else ``"rad"`` (a dataset written before units were recorded).
    """
    units = metadata.get("input_units")
    if units is None:
        units = (metadata.get("units") or {}).get("u", "rad")
    if isinstance(units, str):
        return (units,) * n_inputs
    return tuple(str(u) for u in units)


def _check_names(markers) -> tuple[str, ...]:
    names = tuple(markers)
    if not names or any(not isinstance(n, str) or not n for n in names):
        raise InputError(f"marker names must be non-empty text, the tip first, got {list(names)}")
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise InputError(f"the marker {twice[0]!r} is named twice in {list(names)}")
    return names


def write_dataset(
    path: str | Path,
    u_motor: np.ndarray,
    y_W: np.ndarray,
    metadata: dict,
    *,
    markers=None,
    units=None,
) -> None:
    """Write a dataset as CSV + ``.json`` sidecar, both atomically.

    Parameters
    ----------
    path : str or pathlib.Path
        The CSV file; the sidecar is :func:`sidecar_path` of it.
    u_motor : numpy.ndarray
        Inputs (N, m), each in its unit (rad for angles).
    y_W : numpy.ndarray
        Marker positions (N, 3K), m, frame W, the tip first.
    metadata : dict
        JSON-able fields added to the sidecar (its ``units`` replace the default ones).
    markers : sequence of str, optional
        The K marker names, the tip first; default ``metadata["markers"]``, else the tip only.
    units : sequence of str, optional
        The unit of each input (m,), e.g. ``"rad"`` or ``"N"``; default all ``"rad"``.
    """
    u_motor, y_W = np.asarray(u_motor, float), np.asarray(y_W, float)
    names = _check_names(markers if markers is not None else metadata.get("markers", ("tip",)))
    if u_motor.ndim != 2 or y_W.shape != (len(u_motor), 3 * len(names)):
        raise InputError(
            f"expected u (N, m) and y (N, {3 * len(names)}) for the markers {', '.join(names)}, "
            f"got {u_motor.shape} and {y_W.shape}"
        )
    m = u_motor.shape[1]
    units = tuple(units) if units is not None else ("rad",) * m
    if len(units) != m:
        raise InputError(f"expected one unit per input ({m}), got {list(units)}")
    header = columns(m, names)
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(header)
    for row in np.hstack([u_motor, y_W]):
        writer.writerow([repr(float(v)) for v in row])
    meta = {
        "format_version": FORMAT_VERSION,
        "kind": "lab.dataset",
        "columns": header,
        "units": {"u": "rad" if all(u == "rad" for u in units) else list(units), "xyz": "m"},
        "input_units": list(units),
        "markers": list(names),
        "n_samples": len(u_motor),
        "created": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "code_version": code_version(),
        **metadata,
    }
    data = buf.getvalue().encode()
    meta["csv_sha256"] = hashlib.sha256(data).hexdigest()  # read_dataset checks the pair belongs together
    # Both written completely before either replaces an old file; the CSV renamed last.
    atomic_write_group({sidecar_path(path): json.dumps(meta, indent=2, default=json_default) + "\n", path: data})


def sidecar_path(path: str | Path) -> Path:
    """The metadata sidecar of a dataset CSV.

    Parameters
    ----------
    path : str or pathlib.Path
        The CSV file.

    Returns
    -------
    pathlib.Path
        ``path`` with ``.json`` appended.
    """
    return Path(f"{path}.json")


def read_dataset(path: str | Path) -> tuple[np.ndarray, np.ndarray, dict]:
    """Load a dataset.

    Parameters
    ----------
    path : str or pathlib.Path
        The CSV file (its sidecar is read when present).

    Returns
    -------
    u_motor : numpy.ndarray
        Inputs (N, m), each in its unit (:func:`input_units`).
    y_W : numpy.ndarray
        Marker positions (N, 3K), m, frame W, the tip first (``y_W[:, :3]``).
    metadata : dict
        The sidecar's fields ({} without one); ``markers`` holds the marker names read from
        the header when the sidecar lacks them and there are several (:func:`marker_names`).

    Raises
    ------
    DatasetError
        Naming the problem for a missing file, a bad header (naming the column), a non-numeric or non-finite
        value, a sidecar from a newer format, or a file cut short (one that does not match
        its sidecar's hash, or without one, whose last line lacks the newline every written
        row ends with).
    """
    path = Path(path)
    if not path.exists():
        raise DatasetError(f"dataset not found: {path}")
    if path.is_dir():
        raise DatasetError(f"{path} is a directory, not a dataset CSV")
    meta = {}
    side = sidecar_path(path)
    if side.exists():
        try:
            meta = json.loads(side.read_text())
        except json.JSONDecodeError as err:
            raise DatasetError(f"{side}: corrupt metadata JSON: {err}") from None
        if not isinstance(meta, dict):
            raise DatasetError(f"{side}: the metadata must be a JSON object, not {type(meta).__name__}")
        version = meta.get("format_version")
        if not isinstance(version, int) or version > FORMAT_VERSION:
            raise DatasetError(
                f"{side}: format_version {version!r} is not supported "
                f"(this code reads up to {FORMAT_VERSION}); update the package"
            )
    raw = path.read_bytes()
    try:
        text = raw.decode()
    except UnicodeDecodeError:
        raise DatasetError(f"{path}: not a text CSV file") from None
    rows = list(csv.reader(io.StringIO(text, newline="")))
    if not rows:
        raise DatasetError(f"{path}: empty file")
    header = rows[0]
    m, names = _parse_header(path, header)
    if "markers" in meta and list(meta["markers"]) != list(names):
        raise DatasetError(
            f"{path}: the header's markers {', '.join(names)} differ from its sidecar's "
            f"{', '.join(map(str, meta['markers']))}"
        )
    if len(names) > 1:
        meta.setdefault("markers", list(names))
    width = len(header)
    data = np.empty((len(rows) - 1, width))
    for i, row in enumerate(rows[1:], start=2):
        if len(row) != width:
            raise DatasetError(f"{path}: line {i} has {len(row)} fields, expected {width}")
        try:
            data[i - 2] = [float(v) for v in row]
        except ValueError:
            raise DatasetError(f"{path}: line {i} has a non-numeric value: {row}") from None
    if "csv_sha256" not in meta and not text.endswith("\n"):  # with the hash, the check below says more
        last = text.count("\n") + 1
        raise DatasetError(
            f"{path}: line {last} does not end with a newline: the file looks cut short (its last "
            "row may end in a partial number), and no sidecar hash can tell; if that row is complete, end the file "
            "with a newline"
        )
    if not np.all(np.isfinite(data)):
        bad = int(np.argwhere(~np.isfinite(data))[0, 0]) + 2
        raise DatasetError(f"{path}: line {bad} has a NaN or infinite value")
    if meta.get("n_samples") not in (None, len(data)):
        raise DatasetError(f"{path}: {len(data)} rows but the sidecar says {meta['n_samples']} (truncated?)")
    if "csv_sha256" in meta and hashlib.sha256(raw).hexdigest() != meta["csv_sha256"]:
        raise DatasetError(
            f"{path}: the data does not match its sidecar {side.name} (edited, cut short or a stale sidecar: "
            "its csv_sha256 differs); regenerate the dataset with the command in the sidecar"
        )
    return data[:, :m], data[:, m:], meta


def _parse_header(path, header: list[str]) -> tuple[int, tuple[str, ...]]:
    """The number of inputs and the marker names of a dataset header; DatasetError naming
    the first column that breaks ``u0..u{m-1}, x, y, z, NAME_x, NAME_y, NAME_z, ...``."""
    form = "u0,...,u{m-1},x,y,z then NAME_x,NAME_y,NAME_z per further marker"
    m = 0
    while m < len(header) and header[m] == f"u{m}":
        m += 1
    rest = header[m:]
    if m < 1:
        raise DatasetError(f"{path}: header must be {form}, got {','.join(header)} (no input column u0)")
    if rest[:3] != ["x", "y", "z"]:
        j = next(j for j, want in enumerate("xyz") if j >= len(rest) or rest[j] != want)
        where = f"column {m + j + 1} ({rest[j]!r})" if j < len(rest) else "after the inputs (too few columns)"
        raise DatasetError(f"{path}: header must be {form}, got {','.join(header)}: {where} should be x, y, z")
    names = ["tip"]
    for k in range(3, len(rest), 3):
        triple = rest[k : k + 3]
        name = triple[0][:-2] if triple[0].endswith("_x") else None
        want = [f"{name}_{a}" for a in "xyz"] if name else None
        if not name or triple != want:
            bad = next((j for j, c in enumerate(triple) if not want or j >= len(want) or c != want[j]), len(triple))
            col = triple[bad] if bad < len(triple) else None
            shown = f"column {m + k + bad + 1} ({col!r})" if col is not None else "the last marker (too few columns)"
            raise DatasetError(
                f"{path}: header must be {form}, got {','.join(header)}: {shown} breaks the marker triple "
                f"{','.join(triple)} (expected NAME_x,NAME_y,NAME_z)"
            )
        if name in names:
            raise DatasetError(f"{path}: the marker {name!r} is named twice in the header (column {m + k + 1})")
        names.append(name)
    return m, tuple(names)
