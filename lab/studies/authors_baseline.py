"""The ASL Trunk authors' own baseline, reproduced, and any model judged on their split.

The authors of the ASL Trunk data fitted a linear least-squares map from the six motor
efforts to all nine disk coordinates: the positions centred on the first row (the trunk at
rest), no intercept, trained on the first 80 % of the September 2024 set in measurement
order and tested on the last 20 %, and reported the RMS over every test coordinate
(14.2 mm). :func:`authors_baseline` repeats exactly that; :func:`sequential_split` is the
split, and :func:`split_rmse` scores any fitted model on it with the same metric, so that a
lab model and their baseline are compared on the same rows and the same outputs.
:func:`asl_nine_coordinates` reads the shipped raw files (``data/third_party/asl-trunk``)
through the importer with all nine columns, not only the tip a lab dataset keeps.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from lab.data.import_spec import ImportSpec
from lab.data.importing import read_measurements
from lab.errors import InputError

__all__ = ["NINE", "SEPTEMBER_FILES", "asl_nine_coordinates", "sequential_split", "authors_baseline", "split_rmse"]

#: The nine disk coordinates of the ASL Trunk, disk 1 (top) to disk 3 (the tip).
NINE = ("x1", "y1", "z1", "x2", "y2", "z2", "x3", "y3", "z3")
#: The September 2024 set: inputs, observations (paired row by row), under the raw folder.
SEPTEMBER_FILES = ("control_inputs_uniform_sep2024_669rows@419a78d.csv", "steady_state_ik_y-up_200g.csv")


def asl_nine_coordinates(raw_dir: str | Path, files: tuple[str, str] = SEPTEMBER_FILES):
    """The efforts ``u`` (N, 6) and all nine disk coordinates ``y`` (N, 9) m of one ASL pair."""
    raw = Path(raw_dir)
    spec = ImportSpec(u=("u1", "u2", "u3", "u4", "u5", "u6"), y=NINE, u_unit="effort")
    m = read_measurements(spec, [raw / files[0]], observations=[raw / files[1]])
    return m.u, m.y_m


def sequential_split(n_rows: int, train_fraction: float = 0.8) -> tuple[np.ndarray, np.ndarray]:
    """The first ``int(train_fraction * n_rows)`` rows (training) and the rest (test), in
    measurement order: index arrays."""
    if not 0 < train_fraction < 1:
        raise InputError(f"train_fraction must be in (0, 1), got {train_fraction}")
    k = int(train_fraction * n_rows)
    if k < 1 or k >= n_rows:
        raise InputError(f"a {train_fraction:g} split of {n_rows} rows leaves an empty set")
    return np.arange(k), np.arange(k, n_rows)


def split_rmse(y_true: np.ndarray, y_pred: np.ndarray) -> float:
    """RMS over every coordinate of every row, m: the authors' metric (not a 3-D distance)."""
    y_true, y_pred = np.asarray(y_true, float), np.asarray(y_pred, float)
    return float(np.sqrt(np.mean((y_true - y_pred) ** 2)))


def authors_baseline(u: np.ndarray, y: np.ndarray, train_fraction: float = 0.8) -> dict:
    """Their linear fit: ``y - y[0] = u H`` by least squares on the sequential training rows.

    Parameters: ``u`` (N, m) commands, ``y`` (N, d) positions in m, in measurement order.
    Returns a dict: ``rmse_m`` on the test rows, ``H`` (m, d), ``train``/``test`` indices,
    ``predict`` (a function u (n, m) -> y (n, d) m)."""
    u, y = np.asarray(u, float), np.asarray(y, float)
    train, test = sequential_split(len(u), train_fraction)
    rest = y[0]
    H = np.linalg.lstsq(u[train], y[train] - rest, rcond=None)[0]

    def predict(u_new):
        return np.asarray(u_new, float) @ H + rest

    return {"rmse_m": split_rmse(y[test], predict(u[test])), "H": H, "train": train, "test": test, "predict": predict}
