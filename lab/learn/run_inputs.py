"""What ``train`` and ``splits`` fit on: dataset files to inputs, split groups, model metadata.

:func:`read_all` reads a dataset and any ``--extra-data`` files of the same robot (each
sample given once: a repeated row would sit on both sides of the split) with the sequence
of every row (:func:`lab.data.sequences.sequence_ids`; each extra file's sequences are its
own). :func:`inputs_and_groups` turns them into the model's inputs -- the commands, or with
``--history K`` the :func:`lab.learn.history.history_features` of the sequences, refusing
K not below the longest sequence -- and, for ``--split group``, the groups dealt out
(:func:`lab.learn.split.split_groups`: the sequences, or contiguous blocks, with a note,
when there are fewer than 3). :func:`record_trained` writes what every trained model
records: its history K, the box of its training commands
(:func:`lab.learn.history.record_data_bounds`) and the robot of a dataset without an FEM
(sidecar ``robot.kind == "measured"``), whose limits and units then travel with the model;
:func:`forward_model` loads the forward model that judges a direct inverse's commands.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

from lab.data.dataset import read_dataset
from lab.data.sequences import sequence_ids
from lab.errors import InputError
from lab.learn.history import check_history_fits, history_features, record_data_bounds, record_history
from lab.learn.models import load_model
from lab.learn.outputs import record_io
from lab.learn.split import split_groups

__all__ = ["forward_model", "inputs_and_groups", "read_all", "record_trained"]


def _check_not_twice(sources: list[tuple[str, np.ndarray]], what: str, rows: np.ndarray) -> None:
    """Refuse an ``--extra-data`` file ``what`` whose (u, y) ``rows`` repeat a sample of an
    earlier file (``sources``: (name, rows) each): copies of one sample on both sides of the
    split would put test samples into training."""
    for name, old in sources:
        index = {r.tobytes(): i for i, r in enumerate(old)}
        dup = [(i, index[r.tobytes()]) for i, r in enumerate(rows) if r.tobytes() in index]
        if dup:
            (i, j), more = dup[0], len(dup) - 1
            raise InputError(
                f"{what}: line {i + 2} is the same sample as line {j + 2} of {name}"
                + (f" ({more} more rows are repeated)" if more else "")
                + "; each sample may be given once (copies would end up on both sides of the split)"
            )


def read_all(data, extra_data) -> tuple[np.ndarray, np.ndarray, dict, list, np.ndarray]:
    """(u (N, m), y (N, 3K) m of K markers, DATA's sidecar, the extra files' provenance, the sequence of
    each row (N,) ints) of the dataset file ``data`` with ``extra_data`` files appended."""
    u, y, meta = read_dataset(data)
    ids = sequence_ids(meta, len(u), where=f"{data}.json")
    extra, seen = [], {Path(data).resolve(): "DATA"}
    sources = [(f"DATA {data}", np.hstack([u, y]))]
    for path in extra_data:
        same = seen.get(Path(path).resolve())
        if same is not None:
            raise InputError(f"extra dataset {path} is the same file as {same}: each dataset may be given once")
        seen[Path(path).resolve()] = f"extra dataset {path}"
        u_x, y_x, meta_x = read_dataset(path)
        robot_x, robot = ((m.get("robot") or {}).get("name") for m in (meta_x, meta))
        if u_x.shape[1] != u.shape[1] or robot_x != robot:
            raise InputError(
                f"extra dataset {path}: robot {robot_x!r} with {u_x.shape[1]} motors, but {data} is robot "
                f"{robot!r} with {u.shape[1]}"
            )
        if y_x.shape[1] != y.shape[1] or meta_x.get("markers") != meta.get("markers"):
            raise InputError(
                f"extra dataset {path}: markers {meta_x.get('markers') or ['tip']} ({y_x.shape[1]} output columns), "
                f"but {data} has {meta.get('markers') or ['tip']} ({y.shape[1]})"
            )
        rows = np.hstack([u_x, y_x])
        _check_not_twice(sources, f"extra dataset {path}", rows)
        sources.append((f"extra dataset {path}", rows))
        ids_x = sequence_ids(meta_x, len(u_x), where=f"{path}.json") + (ids[-1] + 1 if len(ids) else 0)
        u, y, ids = np.vstack([u, u_x]), np.vstack([y, y_x]), np.concatenate([ids, ids_x])
        extra.append({"path": str(path), "file_sha256": hashlib.sha256(Path(path).read_bytes()).hexdigest()})
    return u, y, meta, extra, ids


def inputs_and_groups(spec, u, ids, data, log) -> tuple[np.ndarray, np.ndarray | None, dict]:
    """The model's inputs (N, m (K+1)), the groups of a group split (None for a random
    one) and the report's keys about them (``history``, ``split_method``,
    ``split_groups``, ``n_groups``). InputError for K not below the longest sequence."""
    check_history_fits(spec, spec.history, ids, data)
    runs = np.diff(np.flatnonzero(np.r_[True, ids[1:] != ids[:-1], True])) if len(ids) else np.zeros(1, int)
    x = history_features(u, ids, spec.history) if spec.history else u
    info = {"history": spec.history, "split_method": spec.split, "split_groups": None, "n_groups": None}
    if spec.split != "group":
        return x, None, info
    groups, what = split_groups(ids)
    n_groups = int(np.count_nonzero(groups[1:] != groups[:-1])) + 1
    info.update(split_groups=what, n_groups=n_groups)
    if what == "contiguous_blocks" and log is not None:
        log(
            f"note: {data} has {len(runs)} measurement sequence(s), too few to hold out whole ones; "
            f"the group split cuts the rows into {n_groups} contiguous blocks in measurement order"
        )
    return x, groups, info


def record_trained(model, spec, u, train_idx, meta, io=None) -> None:
    """Metadata every trained model gets: its history K (forward models), the per-motor box
    of its training commands, its output markers and input units (``io``: the pair of
    :func:`lab.learn.outputs.dataset_io`; None: the tip only, rad) and, for a robot without
    an FEM, the sidecar's robot."""
    markers, units = io if io is not None else (("tip",), ("rad",) * u.shape[1])
    record_io(model, markers, units)
    if spec.model != "inverse-mlp":
        record_history(model, spec.history, u.shape[1])
    record_data_bounds(model, u[train_idx])
    robot = meta.get("robot")
    if isinstance(robot, dict) and robot.get("kind") == "measured":
        model.metadata["robot"] = robot


def forward_model(spec, forward):
    """The forward model file ``forward`` loaded, for a spec of ``model="inverse-mlp"``.

    Parameters
    ----------
    spec : lab.learn.train_spec.TrainSpec
        The run's model settings.
    forward : str or Path or None
        A forward model file (.npz), or None.

    Returns
    -------
    object or None
        The loaded model (:func:`lab.learn.models.load_model`), None without ``forward``.
        InputError for a file given with any other model.
    """
    if forward is None:
        return None
    if spec.model != "inverse-mlp":
        raise InputError("a forward model applies only to TrainSpec.model inverse-mlp")
    return load_model(forward)
