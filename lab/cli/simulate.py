"""``python -m lab simulate``: (u, y) pairs of a robot from the FEM, written as a dataset."""

from __future__ import annotations

import argparse
import errno
import shlex
import sys

from lab.cli.paths import check_paths, check_writable, dataset_outputs, existing, ignore_file_size_signal, output_lock
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
    g = s.add_mutually_exclusive_group()
    g.add_argument("--grid", type=int, default=7, metavar="LEVELS", help="grid levels per motor (default 7)")
    g.add_argument("--sobol", type=int, metavar="N", help="N scrambled-Sobol samples instead of a grid")
    s.add_argument("--seed", type=int, default=0, help="seed of the Sobol scrambling")
    s.add_argument("--n-rings", type=int, help="override the description's mesh rings")
    s.add_argument("--n-axial", type=int, help="override the description's mesh layers")
    s.add_argument("--jobs", type=int, default=default_jobs(), help="worker processes (default: all cores)")
    s.add_argument("--out", required=True, help="output CSV; metadata goes to OUT.json")
    s.add_argument("--no-progress", action="store_true", help="no progress bar")
    s.add_argument(
        "--checkpoint",
        metavar="DIR",
        help="where finished chunks are kept until the dataset is written (default OUT.chunks); "
        "running the same command again after a kill resumes from it",
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
    from lab.data.designs import grid_chunks, grid_commands, nearest_neighbour_chunks, sobol_commands
    from lab.data.simulation import simulate
    from lab.fem.linsolve import default_backend
    from lab.fem.mesh import check_mesh_size

    n_rings = robot.n_rings if args.n_rings is None else args.n_rings
    n_axial = robot.n_axial if args.n_axial is None else args.n_axial
    check_mesh_size(n_rings, n_axial)  # before any work: refuse what cannot fit in memory
    if args.sobol is not None:
        u = sobol_commands(robot, args.sobol, seed=args.seed)
        chunks = nearest_neighbour_chunks(u, size=args.chunk_size)
        sampler = {"name": "sobol", "n": args.sobol, "seed": args.seed, "scramble": True}
    else:
        u = grid_commands(robot, args.grid)
        chunks = grid_chunks(robot, u, target_size=args.chunk_size)
        sampler = {"name": "grid", "levels": args.grid, "n_candidates": args.grid**robot.n_cables}
    sampler["n_safe"] = len(u)
    print(
        f"{robot.name}: {len(u)} safe commands, mesh n_rings={n_rings} n_axial={n_axial}, {args.jobs} worker(s)",
        file=sys.stderr,
    )
    if args.restart:
        clear_checkpoint(checkpoint)  # only the checkpoint's own files, never anything else
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
    if res["resumed_samples"]:
        print(f"resumed: {res['resumed_samples']} samples came from {checkpoint}", file=sys.stderr)
    from lab.fem.mesh import cylinder_mesh

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
            "linear_solver": default_backend(),
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
