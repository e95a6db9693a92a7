"""(u, y) datasets on disk: a plain CSV plus a JSON sidecar with versioned metadata.

``DATA.csv`` has the header ``u0,...,u{m-1},x,y,z`` (motor angles in radians, tip
position in metres, frame W) and one row per sample, nothing else. ``DATA.csv.json``
holds the metadata (robot description and hash, mesh, sampler, code version, date).
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


def columns(n_motors: int) -> list[str]:
    """The dataset CSV's header.

    Parameters
    ----------
    n_motors : int
        Number of motors m.

    Returns
    -------
    list of str
        ``u0, ..., u{m-1}, x, y, z``.
    """
    return [f"u{i}" for i in range(n_motors)] + ["x", "y", "z"]


def write_dataset(path: str | Path, u_motor: np.ndarray, p_tip_W: np.ndarray, metadata: dict) -> None:
    """Write a dataset as CSV + ``.json`` sidecar, both atomically.

    Parameters
    ----------
    path : str or pathlib.Path
        The CSV file; the sidecar is :func:`sidecar_path` of it.
    u_motor : numpy.ndarray
        Commands (N, m), rad.
    p_tip_W : numpy.ndarray
        Tips (N, 3), m, frame W.
    metadata : dict
        JSON-able fields added to the sidecar.
    """
    u_motor, p_tip_W = np.asarray(u_motor, float), np.asarray(p_tip_W, float)
    if u_motor.ndim != 2 or p_tip_W.shape != (len(u_motor), 3):
        raise InputError(f"expected u (N, m) and y (N, 3), got {u_motor.shape} and {p_tip_W.shape}")
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(columns(u_motor.shape[1]))
    for row in np.hstack([u_motor, p_tip_W]):
        writer.writerow([repr(float(v)) for v in row])
    meta = {
        "format_version": FORMAT_VERSION,
        "kind": "lab.dataset",
        "columns": columns(u_motor.shape[1]),
        "units": {"u": "rad", "xyz": "m"},
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
        Commands (N, m), rad.
    p_tip_W : numpy.ndarray
        Tips (N, 3), m, frame W.
    metadata : dict
        The sidecar's fields ({} without one).

    Raises
    ------
    DatasetError
        Naming the problem for a missing file, a bad header, a non-numeric or non-finite
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
    m = len(header) - 3
    if m < 1 or header != columns(m):
        raise DatasetError(f"{path}: header must be u0,...,u{{m-1}},x,y,z, got {','.join(header)}")
    data = np.empty((len(rows) - 1, m + 3))
    for i, row in enumerate(rows[1:], start=2):
        if len(row) != m + 3:
            raise DatasetError(f"{path}: line {i} has {len(row)} fields, expected {m + 3}")
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
