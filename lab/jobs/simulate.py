"""``python -m lab simulate``: a sampling design, or given commands, simulated with the FEM into a dataset.

:func:`run` is what the command does with its :class:`lab.data.DesignSpec`: a grid or space-filling
design is solved chunk by chunk (:func:`lab.data.simulated_dataset.simulate_fixed`); an
``--active`` one batch by batch as :func:`lab.learn.active_design.run_active` picks them,
each batch saved in the checkpoint the moment it is solved
(:class:`lab.data.batchstore.BatchStore`), so that the same call after a kill continues
after the last saved batch. ``--commands U.csv`` (:class:`CommandsSpec`): the commands a lab
sent, solved in their order (:func:`lab.data.simulated_dataset.simulate_given`), resumable
like a design. Everything that can be refused is refused before any work.
"""

from __future__ import annotations

import errno
import time
from dataclasses import dataclass

import numpy as np

from lab.data.batchstore import BatchStore
from lab.data.chunkstore import FORMAT_VERSION, clear_checkpoint
from lab.data.commands_file import read_commands
from lab.data.design_spec import DesignSpec
from lab.data.simulated_dataset import announce, simulate_fixed, simulate_given, solve_batch, write_simulated
from lab.description import RobotDescription
from lab.errors import InputError, LabRuntimeError
from lab.fem.bodies.mesh_spec import MeshSpec
from lab.learn.active_design import active_settings, check_active, run_active
from lab.specs import Spec, option

__all__ = ["run", "CommandsSpec"]


@dataclass(frozen=True)
class CommandsSpec(Spec):
    """Given commands instead of a sampling design.

    Attributes
    ----------
    commands : str or None
        A CSV file of the commands a lab sent, one row each, one column per input (``u0..``
        or the cables' names), solved in the file's row order.
    """

    commands: str | None = option(
        help="a CSV file of the commands a lab sent (one column per input, named u0.. or after the cables), "
        "simulated in its row order instead of a sampling design"
    )


#: OS errors that mean the disk, the quota or the file-size limit is full.
_NO_SPACE = {errno.ENOSPC, errno.EFBIG, getattr(errno, "EDQUOT", errno.ENOSPC)}
#: Fields kept per sample: the solver's counts and times, and every marker.
_STATS = ("iterations", "factorizations", "time_s", "y_W")


def run(
    design: DesignSpec,
    robot: RobotDescription,
    mesh: MeshSpec,
    out,
    *,
    checkpoint,
    command: str,
    jobs: int = 1,
    chunk_size: int = 64,
    progress: bool = False,
    scheduler: str | None = None,
    restart: bool = False,
    commands=None,
    file=None,
) -> dict:
    """Simulate ``design`` for ``robot`` on the ``mesh`` and write the dataset ``out`` (+ ``out.json``).

    Parameters
    ----------
    design : DesignSpec
        Which commands: a grid, a space-filling design or an active one.
    robot : RobotDescription
        The robot simulated.
    mesh : MeshSpec
        The FEM mesh (None fields: the description's).
    out : str or Path
        Output dataset CSV; its metadata goes to ``out.json``.
    checkpoint : str or Path
        Directory keeping finished chunks (or batches) until the dataset is written.
    command : str
        The command line recorded in the metadata.
    jobs : int
        Worker processes solving chunks.
    chunk_size : int
        Commands per chunk (a unit of work and of checkpointing).
    progress : bool
        Whether to show a progress bar.
    scheduler : str, optional
        A Dask scheduler (``tcp://HOST:PORT``) to run the chunks on instead of local workers.
    restart : bool
        Discard the checkpoint's files first.
    commands : str or Path, optional
        A CSV file of commands to simulate in its row order instead of ``design``
        (:func:`lab.data.commands_file.read_commands`).
    file : file-like, optional
        Where progress lines go (default stderr).

    Returns
    -------
    dict
        The dataset's metadata. A full disk raises LabRuntimeError saying that the finished
        chunks are kept.
    """
    if isinstance(chunk_size, bool) or not isinstance(chunk_size, int) or chunk_size < 1:
        raise InputError(f"--chunk-size must be a positive integer, got {chunk_size!r}")
    given = None
    if commands is not None:
        given = read_commands(commands, robot)
    else:
        design.check(robot)
        if design.kind == "active":
            check_active(design, robot)
    n_rings, n_axial = mesh.resolve(robot)  # before any work: refuse what cannot fit in memory
    run = dict(jobs=jobs, chunk_size=chunk_size, progress=progress, scheduler=scheduler)
    try:
        if restart:
            clear_checkpoint(checkpoint)  # only the checkpoint's own files, never anything else
        if given is not None:
            u, res, sampler = simulate_given(robot, *given, n_rings, n_axial, checkpoint=checkpoint, file=file, **run)
        elif design.kind == "active":
            u, res, sampler = _simulate_active(robot, design, n_rings, n_axial, checkpoint, file, run)
        else:
            u, res, sampler = simulate_fixed(robot, design, n_rings, n_axial, checkpoint=checkpoint, file=file, **run)
        return write_simulated(
            out,
            robot,
            n_rings,
            n_axial,
            u,
            res,
            sampler,
            checkpoint=checkpoint,
            jobs=jobs,
            scheduler=scheduler,
            command=command,
            file=file,
        )
    except OSError as err:
        if err.errno not in _NO_SPACE:
            raise
        raise LabRuntimeError(
            f"no space left to write {out} or its checkpoint {checkpoint} ({err.strerror}): "
            "free some space (or raise the file-size limit) and run the same command again; "
            "an existing dataset at --out is unchanged and finished chunks are kept"
        ) from err


def _simulate_active(robot, design, n_rings, n_axial, checkpoint, file, run: dict):
    """``--active N --batch B``: each batch simulated as soon as it is picked and saved in
    the checkpoint; a re-run continues after the last saved batch."""
    settings = active_settings(design, robot)
    fp = {
        "format_version": FORMAT_VERSION,
        "kind": "lab.active-checkpoint",
        "robot_sha256": robot.sha256,
        "n_rings": int(n_rings),
        "n_axial": int(n_axial),
        "sampler": settings,
    }
    store = BatchStore(checkpoint, fp)
    batches = store.load_batches()
    stats = {f: [b[f] for b in batches] for f in _STATS}
    log = [b["entry"] for b in batches]
    u_done = np.vstack([np.empty((0, robot.n_inputs))] + [b["u_motor"] for b in batches])
    y_done = np.vstack([np.empty((0, 3))] + [b["p_tip_W"] for b in batches])
    how = f" picked actively in batches of {design.batch}"
    announce(robot, design.active, n_rings, n_axial, run["jobs"], how, file=file)
    solved = {}

    def measure(u_b):
        solved.clear()
        solved.update(solve_batch(robot, u_b, n_rings, n_axial, **run))
        return solved["p_tip_W"]

    def on_batch(u_b, y_b, entry):
        store.save_batch(len(log), {"order": np.arange(len(u_b)), "u_motor": u_b, **solved}, entry)
        log.append(entry)
        for f in _STATS:
            stats[f].append(solved[f])

    t0 = time.perf_counter()
    u, y, _ = run_active(
        design, robot, measure, u_done=u_done, y_done=y_done, n_jobs=run["jobs"], on_batch=on_batch, file=file
    )
    res = {f: np.concatenate(stats[f]) for f in _STATS}
    res.update(p_tip_W=y, wall_s=time.perf_counter() - t0, resumed_samples=len(u_done))
    return u, res, {**settings, "n_batches": len(log), "log": log}
