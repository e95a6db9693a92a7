"""Which motor commands to sample, and the walks (chunks) they are solved in.

Samplers give safe motor commands (N, m) in radians:

* :func:`grid_commands` — ``levels`` equally spaced angles per motor in [0, u_max]
  (the paper's 7x7x7 grid), minus what the safety rule forbids;
* :func:`sobol_commands` — a scrambled Sobol sequence (seeded), safe points only.

Chunkers (:func:`grid_chunks`, :func:`nearest_neighbour_chunks`) cut the commands into
walks whose neighbours are close, so that :func:`lab.data.simulation.simulate` can
warm-start each solve from the last; they depend only on the commands, never on the
number of workers.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from lab.description import RobotDescription
from lab.errors import InputError


@dataclass
class Chunk:
    """Indices into the command array, in the order they are to be solved."""

    order: np.ndarray


def grid_commands(robot: RobotDescription, levels: int) -> np.ndarray:
    """Safe points of the ``levels``^m grid over [0, u_max]^m, lexicographic order (N, m)."""
    if levels < 2:
        raise InputError("a grid needs at least 2 levels per motor")
    axis = np.linspace(0.0, robot.u_max_rad, levels)
    u = np.array(list(itertools.product(axis, repeat=robot.n_cables)))
    return u[robot.is_safe(u)]


def sobol_commands(robot: RobotDescription, n: int, seed: int = 0) -> np.ndarray:
    """``n`` safe commands from a scrambled Sobol sequence over [0, u_max]^m (n, m)."""
    from scipy.stats import qmc

    sampler = qmc.Sobol(d=robot.n_cables, scramble=True, seed=seed)
    out = np.empty((0, robot.n_cables))
    while len(out) < n:
        u = sampler.random_base2(int(np.ceil(np.log2(max(64, 2 * n))))) * robot.u_max_rad
        out = np.vstack([out, u[robot.is_safe(u)]])
    return out[:n]


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
    """Chunks of grid commands: grouped by their leading grid indices, ~``target_size``
    commands each, each walked serpentine so successive commands differ by one step."""
    levels = np.unique(u_motor)
    spacing = np.min(np.diff(levels)) if len(levels) > 1 else robot.u_max_rad
    keys = np.rint(u_motor / spacing).astype(int)
    n_levels = keys.max() + 1
    lead = 0
    while lead < robot.n_cables - 1 and n_levels ** (robot.n_cables - lead) > target_size:
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
    """Chunks of consecutive commands, each ordered by a greedy nearest-neighbour walk
    starting from the command closest to rest (for scattered samples such as Sobol)."""
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
