"""The greedy maximin selection: each next point the one farthest from those picked before.

:func:`greedy_maximin` picks among all candidates, or among a pool that grows with the pick
(``n_candidates``). :func:`lab.data.designs.maximin_commands` picks from safe
scrambled-Sobol commands with a pool of :func:`maximin_pool_size` (k) at the k-th pick,
which depends on k, not on the design's length: so the first k commands of any maximin
design are the k-command design (prefix-stable), and a study that takes its N samples as
the first N of one long design uses, at every N, the commands of a design of N.
"""

from __future__ import annotations

import numpy as np

from lab.errors import InputError

__all__ = ["greedy_maximin", "maximin_pool_size"]


#: The candidates of a maximin design's k-th pick: the first ``max(4096, 32 k)`` safe
#: scrambled-Sobol commands, at most 131,072 (:func:`maximin_pool_size`).
MAXIMIN_POOL_MIN, MAXIMIN_POOL_PER_PICK, MAXIMIN_POOL_CAP = 4096, 32, 131_072


def maximin_pool_size(k: int) -> int:
    """How many candidates the k-th pick of a maximin design chooses among.

    Parameters
    ----------
    k : int
        The pick, 1 for the first.

    Returns
    -------
    int
        ``max(4096, 32 k)``, at most 131,072: the first that many safe scrambled-Sobol commands.
    """
    return min(max(MAXIMIN_POOL_MIN, MAXIMIN_POOL_PER_PICK * int(k)), MAXIMIN_POOL_CAP)


def greedy_maximin(points: np.ndarray, first: int, n: int, n_candidates=None) -> list[int]:
    """Greedy maximin selection: each next point the one farthest from those already picked.

    Parameters
    ----------
    points : numpy.ndarray
        Candidates (P, d), any unit.
    first : int
        Index of the first pick.
    n : int
        How many to pick.
    n_candidates : callable, optional
        ``n_candidates(k) -> int``, non-decreasing: the k-th pick (k = 1..n) chooses among
        the first that many points (at most P; the first pick must be among them). A
        candidate added to the pool starts at its distance to the nearest pick so far.
        None (the default): every pick chooses among all P points.

    Returns
    -------
    list of int
        The indices picked, in order (ties: the lowest index).
    """
    size = (lambda k: len(points)) if n_candidates is None else (lambda k: min(int(n_candidates(k)), len(points)))
    p = size(1)
    if not 0 <= first < p:
        raise InputError(f"the first pick {first} is not among the {p} candidates of the first pick")
    picked = [int(first)]
    d_all = np.empty(max(p, size(n)))  # d_all[:p]: each candidate's distance to its nearest pick
    d_all[:p] = np.linalg.norm(points[:p] - points[first], axis=1)
    for k in range(2, n + 1):
        grown = size(k)
        if grown > p:  # newly added candidates: their distance to the nearest pick so far
            d_all[p:grown] = np.linalg.norm(points[p:grown, None, :] - points[picked][None], axis=2).min(axis=1)
            p = grown
        d_min = d_all[:p]
        j = int(np.argmax(d_min))
        picked.append(j)
        np.minimum(d_min, np.linalg.norm(points[:p] - points[j], axis=1), out=d_min)
    return picked
