"""Measurement sequences of a dataset: which rows were taken one after another.

A sequence is a run of rows measured in order on the robot, so a row's previous command
is the row before it in the same sequence. Imported data (``python -m lab import-data``)
record where each sequence starts in the sidecar key ``sequence_starts`` (row indices,
ascending, starting with 0); a dataset without that key -- simulated or captured here --
is one sequence. History features (:mod:`lab.learn.history`) reset at sequence starts,
and a group split (``--split group``) holds out whole sequences, so that no neighbour of a
test row is trained on.
"""

from __future__ import annotations

import numpy as np

from lab.errors import InputError

__all__ = ["sequence_ids", "sequence_starts_of", "contiguous_blocks"]


def sequence_starts_of(meta: dict, n_rows: int, *, where: str = "the dataset sidecar") -> np.ndarray:
    """The first row of each sequence, from a sidecar dict ``meta``.

    InputError (naming ``where``) for starts that are not ascending integers in
    ``[0, n_rows)`` beginning with 0.

    Parameters
    ----------
    meta : dict
        The dataset's sidecar.
    n_rows : int
        The dataset's rows.
    where : str
        What to name in an error.

    Returns
    -------
    numpy.ndarray
        The starts (k,) int, ascending, starting with 0; ``[0]`` when ``meta`` has no
        ``sequence_starts``.
    """
    starts = meta.get("sequence_starts") if isinstance(meta, dict) else None
    if starts is None:
        return np.zeros(1, dtype=int)
    ok = (
        isinstance(starts, list)
        and len(starts) >= 1
        and all(isinstance(s, int) and not isinstance(s, bool) for s in starts)
        and starts[0] == 0
        and all(a < b for a, b in zip(starts, starts[1:], strict=False))
        and (n_rows == 0 or starts[-1] < n_rows)
    )
    if not ok:
        raise InputError(
            f"{where}: sequence_starts must be ascending row indices starting with 0 and below {n_rows}, got {starts!r}"
        )
    return np.asarray(starts, dtype=int)


def sequence_ids(meta: dict, n_rows: int, *, where: str = "the dataset sidecar") -> np.ndarray:
    """The sequence number of each row.

    Parameters
    ----------
    meta : dict
        The dataset's sidecar.
    n_rows : int
        The dataset's rows.
    where : str
        What to name in an error.

    Returns
    -------
    numpy.ndarray
        (n_rows,) int: 0, 0, ..., 1, 1, ... in row order.
    """
    starts = sequence_starts_of(meta, n_rows, where=where)
    ids = np.zeros(n_rows, dtype=int)
    ids[starts[1:]] = 1
    return np.cumsum(ids)


def contiguous_blocks(n_rows: int, n_blocks: int) -> np.ndarray:
    """Sequence numbers that cut rows in measurement order into contiguous blocks of nearly
    equal size. For a group split of data measured as one long sequence (neighbours in time
    stay on one side of the split).

    Parameters
    ----------
    n_rows : int
        Rows to cut.
    n_blocks : int
        Blocks, 1 to ``n_rows``.

    Returns
    -------
    numpy.ndarray
        (n_rows,) int block number of each row.
    """
    if n_blocks < 1 or n_rows < n_blocks:
        raise InputError(f"cannot cut {n_rows} rows into {n_blocks} contiguous blocks")
    return (np.arange(n_rows) * n_blocks) // n_rows
