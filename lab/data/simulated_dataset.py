"""A fixed sampling design simulated with the FEM and written as a dataset file.

:func:`simulate_fixed` solves the commands of a grid or a space-filling design
(:class:`lab.data.DesignSpec`) chunk by chunk, each finished chunk kept in a checkpoint
directory so that a killed run resumes (:mod:`lab.data.chunkstore`);
:func:`write_simulated` writes the samples with their metadata (robot, mesh, sampler,
solver) as the CSV + JSON pair of :mod:`lab.data.dataset`, then removes the checkpoint.
:func:`simulate_given` solves commands given in a file (``simulate --commands``) in their
order, resumable the same way. :func:`solve_batch` solves one batch without a checkpoint (an active design's batches are
kept by their caller).
"""

from __future__ import annotations

import sys

import numpy as np

from lab.data import simulation
from lab.data.chunks import grid_chunks, nearest_neighbour_chunks, ordered_chunks
from lab.data.chunkstore import remove_checkpoint
from lab.data.dataset import write_dataset
from lab.data.design_spec import DesignSpec
from lab.description import RobotDescription
from lab.fem.bodies import body_of
from lab.fem.bodies.mesh_spec import mesh_label

__all__ = ["simulate_fixed", "simulate_given", "solve_batch", "write_simulated", "announce"]


def announce(robot: RobotDescription, n: int, n_rings: int, n_axial: int, jobs: int, how: str = "", file=None):
    """The line that opens a simulation run (on ``file``, default stderr)."""
    mesh = mesh_label(robot, n_rings, n_axial)
    print(
        f"{robot.name}: {n} safe commands{how}, mesh {mesh}, {jobs} worker(s)",
        file=sys.stderr if file is None else file,
    )


def simulate_fixed(
    robot: RobotDescription,
    design: DesignSpec,
    n_rings: int,
    n_axial: int,
    *,
    checkpoint,
    jobs: int = 1,
    chunk_size: int = 64,
    progress: bool = False,
    scheduler: str | None = None,
    file=None,
) -> tuple[np.ndarray, dict, dict]:
    """Simulate a grid or space-filling design.

    Parameters
    ----------
    robot : RobotDescription
        The robot.
    design : DesignSpec
        A grid or space-filling design (not ``active``).
    n_rings, n_axial : int
        The mesh's resolution.
    checkpoint : str or os.PathLike or None
        Where chunks of ``chunk_size`` commands are kept as they finish.
    jobs : int
        Worker processes.
    chunk_size : int
        Commands per walk.
    progress : bool
        Show a progress bar.
    scheduler : str, optional
        A Dask scheduler's address.
    file : file-like, optional
        Where the opening line goes (default stderr).

    Returns
    -------
    u : numpy.ndarray
        The commands (N, m), rad.
    res : dict
        The solver's result (:func:`lab.data.simulation.simulate`: ``p_tip_W`` (N, 3) m,
        ``y_W`` (N, 3K) m, per-sample stats, ``wall_s``, ``resumed_samples``).
    sampler : dict
        The sampler's metadata.
    """
    u, sampler = design.commands(robot)
    sampler["n_safe"] = len(u)
    if design.method == "sobol":
        sampler["scramble"] = True
    if design.kind == "grid":
        chunks = grid_chunks(robot, u, target_size=chunk_size)
    else:
        chunks = nearest_neighbour_chunks(u, size=chunk_size)
    announce(robot, len(u), n_rings, n_axial, jobs, file=file)
    res = simulation.simulate(
        robot,
        u,
        chunks,
        n_rings=n_rings,
        n_axial=n_axial,
        n_jobs=jobs,
        progress=progress,
        checkpoint=checkpoint,
        scheduler=scheduler,
    )
    return u, res, sampler


def simulate_given(
    robot: RobotDescription,
    u: np.ndarray,
    source: dict,
    n_rings: int,
    n_axial: int,
    *,
    checkpoint,
    jobs: int = 1,
    chunk_size: int = 64,
    progress: bool = False,
    scheduler: str | None = None,
    file=None,
) -> tuple[np.ndarray, dict, dict]:
    """Simulate given commands in the order given: consecutive chunks of ``chunk_size``
    commands, each one walk warm-started from the last solve (the first from rest), never
    reordered; each finished chunk kept in ``checkpoint``.

    Parameters
    ----------
    robot : RobotDescription
        The robot.
    u : numpy.ndarray
        The commands (N, m), each input in its unit, in the order sent.
    source : dict
        Where they come from (:func:`lab.data.commands_file.read_commands`'s record).
    n_rings, n_axial : int
        The mesh's resolution.
    checkpoint : str or os.PathLike or None
        Where finished chunks are kept.
    jobs : int
        Worker processes.
    chunk_size : int
        Commands per walk (and per checkpointed chunk).
    progress : bool
        Show a progress bar.
    scheduler : str, optional
        A Dask scheduler's address.
    file : file-like, optional
        Where the opening line goes (default stderr).

    Returns
    -------
    u : numpy.ndarray
        The commands (N, m), as given.
    res : dict
        The solver's result (:func:`lab.data.simulation.simulate`).
    sampler : dict
        The sampler's metadata: ``name`` "commands", the file's record, ``chunk_size``.
    """
    chunks = ordered_chunks(len(u), size=chunk_size)
    announce(robot, len(u), n_rings, n_axial, jobs, f" from {source['path']} in the order given", file=file)
    res = simulation.simulate(
        robot,
        u,
        chunks,
        n_rings=n_rings,
        n_axial=n_axial,
        n_jobs=jobs,
        progress=progress,
        checkpoint=checkpoint,
        scheduler=scheduler,
    )
    sampler = {"name": "commands", **source, "order": "as given", "chunk_size": chunk_size, "n_safe": len(u)}
    return u, res, sampler


def solve_batch(
    robot: RobotDescription,
    u_batch: np.ndarray,
    n_rings: int,
    n_axial: int,
    *,
    jobs: int = 1,
    chunk_size: int = 64,
    progress: bool = False,
    scheduler: str | None = None,
) -> dict:
    """One batch of commands solved in nearest-neighbour walks, without a checkpoint.

    Parameters
    ----------
    robot : RobotDescription
        The robot.
    u_batch : numpy.ndarray
        Commands (B, m), rad.
    n_rings, n_axial : int
        The mesh's resolution.
    jobs, chunk_size : int
        Worker processes, and commands per walk.
    progress : bool
        Show a progress bar.
    scheduler : str, optional
        A Dask scheduler's address.

    Returns
    -------
    dict
        :func:`lab.data.simulation.simulate`'s result (``p_tip_W`` (B, 3) m, ``y_W`` (B, 3K) m, ...).
    """
    return simulation.simulate(
        robot,
        u_batch,
        nearest_neighbour_chunks(u_batch, size=chunk_size),
        n_rings=n_rings,
        n_axial=n_axial,
        n_jobs=jobs,
        progress=progress,
        scheduler=scheduler,
    )


def write_simulated(
    out,
    robot: RobotDescription,
    n_rings: int,
    n_axial: int,
    u: np.ndarray,
    res: dict,
    sampler: dict,
    *,
    checkpoint,
    jobs: int,
    scheduler: str | None,
    command: str,
    file=None,
) -> dict:
    """Write the dataset ``out`` (+ ``out.json``) of commands ``u`` (N, m) and the solver's
    result ``res`` (every marker of the robot, the tip first), then remove the
    ``checkpoint`` it now holds; returns the metadata written. Prints where resumed
    samples came from and what was written.

    Parameters
    ----------
    out : str or pathlib.Path
        The dataset CSV.
    robot : RobotDescription
        The robot simulated.
    n_rings, n_axial : int
        The mesh's resolution.
    u : numpy.ndarray
        Commands (N, m), each input in its unit (rad, N).
    res : dict
        :func:`lab.data.simulation.simulate`'s result for ``u`` (``p_tip_W`` (N, 3) m and
        ``y_W`` (N, 3K) m).
    sampler : dict
        The sampler's metadata.
    checkpoint : str or os.PathLike or None
        The checkpoint to remove once written.
    jobs : int
        Worker processes used (recorded).
    scheduler : str or None
        The Dask scheduler used (recorded).
    command : str
        The command line (recorded).
    file : file-like, optional
        Where the messages go (default stderr).

    Returns
    -------
    dict
        The sidecar's metadata as written.
    """
    from lab.fem.solve.linsolve import default_backend

    file = sys.stderr if file is None else file
    if res["resumed_samples"]:
        print(f"resumed: {res['resumed_samples']} samples came from {checkpoint}", file=file)
    mesh = body_of(robot, n_rings=n_rings, n_axial=n_axial).mesh  # counts only (a cached mesh for a file)
    meta = {
        "robot": {"name": robot.name, "sha256": robot.sha256, "description": robot.source},
        "mesh": {
            "mesher": robot.body_shape.shape,
            "n_rings": n_rings,
            "n_axial": n_axial,
            "n_nodes": mesh.n_nodes,
            "n_tets": len(mesh.tets),
        },
        "sampler": sampler,
        "solver": {
            "linear_solver": default_backend(),
            "mean_newton_iterations": float(res["iterations"].mean()),
            "wall_s": res["wall_s"],
            "n_jobs": jobs,
            "scheduler": scheduler,
            "resumed_samples": res["resumed_samples"],
        },
        "command": command,
    }
    # the tip's columns are the solver's tip, exactly as a tip-only dataset always held it
    y = np.hstack([res["p_tip_W"], np.asarray(res.get("y_W", res["p_tip_W"]))[:, 3:]])
    write_dataset(out, u, y, meta, markers=robot.marker_names, units=robot.input_units)
    remove_checkpoint(checkpoint)  # the dataset now holds every chunk
    print(
        f"wrote {len(u)} samples to {out} in {res['wall_s']:.1f} s "
        f"(mean {res['iterations'].mean():.2f} Newton iterations)",
        file=file,
    )
    return meta
