"""``python -m lab simulate``: (u, y) pairs of a robot from the FEM, written as a dataset."""

from __future__ import annotations

import argparse
import errno
import shlex
import sys

from lab.cli.paths import check_paths, check_writable, dataset_outputs, existing, ignore_file_size_signal, output_lock
from lab.cli.sampling import add_sampler_args, check_sampler_args
from lab.errors import LabRuntimeError
from lab.workers import default_jobs

#: OS errors that mean the disk, the quota or the file-size limit is full.
_NO_SPACE = {errno.ENOSPC, errno.EFBIG, getattr(errno, "EDQUOT", errno.ENOSPC)}


def add_parser(subparsers, parents=()) -> argparse.ArgumentParser:
    """Add this command to an ``argparse`` subparsers object; returns its parser."""
    s = subparsers.add_parser(
        "simulate", parents=parents, help="simulate (u, y) pairs of a robot with the FEM and write a dataset"
    )
    s.add_argument("--robot", default="three-cable", help="shipped robot name or path to a TOML description")
    add_sampler_args(s)
    s.add_argument("--seed", type=int, default=0, help="seed of the design (or of --active's picks and ensembles)")
    s.add_argument("--n-rings", type=int, help="override the description's mesh rings")
    s.add_argument("--n-axial", type=int, help="override the description's mesh layers")
    s.add_argument("--jobs", type=int, default=default_jobs(), help="worker processes (default: all cores)")
    s.add_argument("--out", required=True, help="output CSV; metadata goes to OUT.json")
    s.add_argument("--no-progress", action="store_true", help="no progress bar")
    s.add_argument(
        "--checkpoint",
        metavar="DIR",
        help="where finished chunks (--active: batches) are kept until the dataset is written "
        "(default OUT.chunks); running the same command again after a kill resumes from it",
    )
    s.add_argument(
        "--chunk-size",
        type=int,
        default=64,
        help="commands per chunk (a unit of work and of checkpointing; default 64)",
    )
    s.add_argument("--restart", action="store_true", help="discard an existing checkpoint and start over")
    s.add_argument(
        "--scheduler",
        metavar="tcp://HOST:PORT",
        help="run the chunks on this Dask scheduler instead of local worker processes",
    )
    s.set_defaults(func=run)

    return s


def run(args) -> int:
    from lab.data.chunkstore import check_checkpoint
    from lab.description import load_robot

    check_sampler_args(args)
    checkpoint = args.checkpoint or f"{args.out}.chunks"
    check_paths(
        {"--robot": existing(args.robot)},
        # the lock file is written (and removed) too: it must not be an input either
        {**dataset_outputs("--out", args.out), "--out lock": f"{args.out}.lock", "--checkpoint": checkpoint},
    )
    check_writable(args.out)
    check_checkpoint(checkpoint)  # a checkpoint under a file fails now, not after the first chunk
    ignore_file_size_signal()  # a write past `ulimit -f` fails with EFBIG, reported below
    robot = load_robot(args.robot)
    with output_lock(args.out):
        try:
            return _simulate(args, robot, checkpoint)
        except OSError as err:
            if err.errno not in _NO_SPACE:
                raise
            raise LabRuntimeError(
                f"no space left to write {args.out} or its checkpoint {checkpoint} ({err.strerror}): "
                "free some space (or raise the file-size limit) and run the same command again; "
                "an existing dataset at --out is unchanged and finished chunks are kept"
            ) from err


def _simulate(args, robot, checkpoint) -> int:
    from lab.data.chunkstore import clear_checkpoint, remove_checkpoint
    from lab.data.dataset import write_dataset
    from lab.fem.mesh import check_mesh_size, cylinder_mesh

    n_rings = robot.n_rings if args.n_rings is None else args.n_rings
    n_axial = robot.n_axial if args.n_axial is None else args.n_axial
    check_mesh_size(n_rings, n_axial)  # before any work: refuse what cannot fit in memory
    if args.restart:
        clear_checkpoint(checkpoint)  # only the checkpoint's own files, never anything else
    run = _active if args.active is not None else _fixed
    u, res, sampler = run(args, robot, checkpoint, n_rings, n_axial)
    if res["resumed_samples"]:
        print(f"resumed: {res['resumed_samples']} samples came from {checkpoint}", file=sys.stderr)
    mesh = cylinder_mesh(robot.length_m, robot.radius_m, n_rings, n_axial)  # counts only
    meta = {
        "robot": {"name": robot.name, "sha256": robot.sha256, "description": robot.source},
        "mesh": {
            "mesher": "cylinder",
            "n_rings": n_rings,
            "n_axial": n_axial,
            "n_nodes": mesh.n_nodes,
            "n_tets": len(mesh.tets),
        },
        "sampler": sampler,
        "solver": {
            "linear_solver": _backend(),
            "mean_newton_iterations": float(res["iterations"].mean()),
            "wall_s": res["wall_s"],
            "n_jobs": args.jobs,
            "scheduler": args.scheduler,
            "resumed_samples": res["resumed_samples"],
        },
        "command": "python -m lab " + shlex.join(sys.argv[1:]),
    }
    write_dataset(args.out, u, res["p_tip_W"], meta)
    remove_checkpoint(checkpoint)  # the dataset now holds every chunk
    print(
        f"wrote {len(u)} samples to {args.out} in {res['wall_s']:.1f} s "
        f"(mean {res['iterations'].mean():.2f} Newton iterations)",
        file=sys.stderr,
    )
    return 0


def _backend() -> str:
    from lab.fem.linsolve import default_backend

    return default_backend()


def _announce(robot, n, n_rings, n_axial, jobs, how="") -> None:
    print(
        f"{robot.name}: {n} safe commands{how}, mesh n_rings={n_rings} n_axial={n_axial}, {jobs} worker(s)",
        file=sys.stderr,
    )


def _fixed(args, robot, checkpoint, n_rings, n_axial):
    """A grid or a design, simulated chunk by chunk (resumable through the chunk store)."""
    from lab.cli.sampling import fixed_commands
    from lab.data.designs import grid_chunks, nearest_neighbour_chunks
    from lab.data.simulation import simulate

    u, sampler = fixed_commands(args, robot)
    sampler["n_safe"] = len(u)
    if args.design == "sobol":
        sampler["scramble"] = True
    if args.design is None:
        chunks = grid_chunks(robot, u, target_size=args.chunk_size)
    else:
        chunks = nearest_neighbour_chunks(u, size=args.chunk_size)
    _announce(robot, len(u), n_rings, n_axial, args.jobs)
    res = simulate(
        robot,
        u,
        chunks,
        n_rings=n_rings,
        n_axial=n_axial,
        n_jobs=args.jobs,
        progress=not args.no_progress,
        checkpoint=checkpoint,
        scheduler=args.scheduler,
    )
    return u, res, sampler


def _active(args, robot, checkpoint, n_rings, n_axial):
    """``--active N --batch B``: each batch simulated as soon as it is picked and saved in
    the checkpoint (:class:`lab.data.batchstore.BatchStore`); a re-run continues after the
    last saved batch."""
    import functools
    import time

    import numpy as np

    from lab.cli.sampling import active_settings, print_batch
    from lab.data.batchstore import BatchStore
    from lab.data.chunkstore import FORMAT_VERSION
    from lab.data.designs import nearest_neighbour_chunks
    from lab.data.simulation import simulate
    from lab.learn.active import active_sampling
    from lab.learn.ensemble import train_ensemble

    settings = active_settings(args, robot)
    kwargs = settings.pop("kwargs")
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
    fields = ("iterations", "factorizations", "time_s")
    stats = {f: [b[f] for b in batches] for f in fields}
    log = [b["entry"] for b in batches]
    u_done = np.vstack([np.empty((0, robot.n_cables))] + [b["u_motor"] for b in batches])
    y_done = np.vstack([np.empty((0, 3))] + [b["p_tip_W"] for b in batches])
    _announce(robot, args.active, n_rings, n_axial, args.jobs, f" picked actively in batches of {args.batch}")
    solved = {}

    def measure(u_b):
        solved.clear()
        solved.update(
            simulate(
                robot,
                u_b,
                nearest_neighbour_chunks(u_b, size=args.chunk_size),
                n_rings=n_rings,
                n_axial=n_axial,
                n_jobs=args.jobs,
                progress=not args.no_progress,
                scheduler=args.scheduler,
            )
        )
        return solved["p_tip_W"]

    def on_batch(u_b, y_b, entry):
        order = np.arange(len(u_b))
        store.save_batch(len(log), {"order": order, "u_motor": u_b, **solved}, entry)
        log.append(entry)
        for f in fields:
            stats[f].append(solved[f])
        print_batch(entry, args.active, sys.stderr)

    t0 = time.perf_counter()
    fit = functools.partial(train_ensemble, n_jobs=args.jobs)  # members on the workers; same result
    u, y, _ = active_sampling(
        robot,
        measure,
        args.active,
        args.batch,
        u_done=u_done,
        y_done=y_done,
        fit_ensemble=fit,
        on_batch=on_batch,
        **kwargs,
    )
    res = {f: np.concatenate(stats[f]) for f in fields}
    res.update(p_tip_W=y, wall_s=time.perf_counter() - t0, resumed_samples=len(u_done))
    return u, res, {**settings, "n_batches": len(log), "log": log}
