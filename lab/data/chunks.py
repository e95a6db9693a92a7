"""The walks (chunks) that sampled commands are solved in.

Chunkers (:func:`grid_chunks`, :func:`nearest_neighbour_chunks`) cut the commands of
:mod:`lab.data.designs` into walks whose neighbours are close (:func:`ordered_chunks` keeps
given commands in their order), so that
:func:`lab.data.simulation.simulate` can warm-start each solve from the last; they depend
only on the commands, never on the number of workers. :func:`nearest_walk` is the one walk
through a small set of scattered commands (the real samples of a calibration, the probe
commands of an emulated robot), from rest.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lab.description import RobotDescription


@dataclass
class Chunk:
    """One walk of commands.

    Attributes
    ----------
    order : numpy.ndarray
        Indices (int) into the command array, in the order they are to be solved.
    """

    order: np.ndarray


def _serpentine(keys: np.ndarray) -> np.ndarray:
    """Order integer grid keys (N, d) boustrophedon-style: coordinate j runs backwards
    when the coordinates before it sum to an odd number, so on a full grid consecutive
    points differ by one step in one coordinate."""
    sort_keys = keys.copy()
    for j in range(1, keys.shape[1]):
        odd = keys[:, :j].sum(axis=1) % 2 == 1
        sort_keys[:, j] = np.where(odd, -keys[:, j], keys[:, j])
    return np.lexsort(sort_keys.T[::-1])


def grid_chunks(robot: RobotDescription, u_motor: np.ndarray, target_size: int = 64) -> list[Chunk]:
    """Chunks of grid commands, each walked serpentine so successive commands differ by one step.

    Parameters
    ----------
    robot : RobotDescription
        Gives m and each input's range.
    u_motor : numpy.ndarray
        Grid commands (N, m), each input in its unit.
    target_size : int
        About how many commands per chunk; grouped by their leading grid indices.

    Returns
    -------
    list of Chunk
        The walks, covering every command once.
    """
    lo, hi = np.asarray(robot.u_lower, float), np.asarray(robot.u_upper, float)
    keys = np.zeros(np.shape(u_motor), dtype=int)
    for j in range(keys.shape[1]):  # each input's own grid step (its unit and range)
        levels = np.unique(u_motor[:, j])
        spacing = np.min(np.diff(levels)) if len(levels) > 1 else (hi[j] - lo[j] or 1.0)
        keys[:, j] = np.rint((u_motor[:, j] - lo[j]) / spacing).astype(int)
    n_levels = keys.max() + 1
    lead = 0
    while lead < robot.n_inputs - 1 and n_levels ** (robot.n_inputs - lead) > target_size:
        lead += 1
    groups: dict[tuple, list[int]] = {}
    for i, k in enumerate(keys):
        groups.setdefault(tuple(k[:lead]), []).append(i)
    chunks = []
    for _, idx in sorted(groups.items()):
        idx = np.asarray(idx)
        # Serpentine over the trailing indices only, so every chunk starts near rest.
        chunks.append(Chunk(idx[_serpentine(keys[idx][:, lead:])]))
    return chunks


def nearest_neighbour_chunks(u_motor: np.ndarray, size: int = 64) -> list[Chunk]:
    """Chunks of consecutive commands, each a greedy nearest-neighbour walk from the
    command closest to rest (for scattered samples such as Sobol).

    Parameters
    ----------
    u_motor : numpy.ndarray
        The commands (N, m), rad.
    size : int
        Commands per chunk (the last may be shorter).

    Returns
    -------
    list of Chunk
        The walks, covering every command once.
    """
    chunks = []
    for start in range(0, len(u_motor), size):
        idx = np.arange(start, min(start + size, len(u_motor)))
        left = list(idx)
        cur = min(left, key=lambda i: np.linalg.norm(u_motor[i]))
        order = []
        while left:
            left.remove(cur)
            order.append(cur)
            if left:
                cur = min(left, key=lambda i: np.linalg.norm(u_motor[i] - u_motor[cur]))
        chunks.append(Chunk(np.asarray(order)))
    return chunks


def nearest_walk(u_motor) -> np.ndarray:
    """A greedy nearest-neighbour walk through the commands (L1 distance), starting from the
    one nearest rest: the order in which warm-started solves of scattered commands each start
    near a solved one.

    Parameters
    ----------
    u_motor : array_like
        The commands, shape (N, m), each input in its unit (rad, N, Pa).

    Returns
    -------
    numpy.ndarray
        Indices (N,) into ``u_motor``, every command once; ties go to the lower index.
    """
    u = np.asarray(u_motor, float)
    left, order, here = list(range(len(u))), [], np.zeros(u.shape[1])
    while left:
        j = left[int(np.argmin(np.abs(u[left] - here).sum(axis=1)))]
        order.append(j)
        left.remove(j)
        here = u[j]
    return np.asarray(order, dtype=int)


def ordered_chunks(n: int, size: int = 64) -> list[Chunk]:
    """Chunks of consecutive commands in the order given, never reordered (commands a lab
    sent, ``simulate --commands``): chunk k walks commands ``k*size .. (k+1)*size - 1``.

    Parameters
    ----------
    n : int
        Number of commands.
    size : int
        Commands per chunk (the last may be shorter).

    Returns
    -------
    list of Chunk
        The walks, covering every command once, in order.
    """
    return [Chunk(np.arange(start, min(start + size, n))) for start in range(0, n, size)]
