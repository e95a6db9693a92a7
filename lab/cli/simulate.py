"""``python -m lab simulate``: (u, y) pairs of a robot from the FEM, written as a dataset.

The flags become a :class:`lab.data.DesignSpec` (which commands; or ``--commands U.csv``,
the commands a lab sent, solved in their order) and a
:class:`lab.fem.MeshSpec` (which mesh); :func:`lab.jobs.simulate.run` does the rest,
resumable from its checkpoint.
"""

from __future__ import annotations

import argparse
import shlex
import sys

from lab.cli.flags import add_spec_flags, refuse_unused, spec_from_args
from lab.cli.paths import check_paths, check_writable, dataset_outputs, existing, ignore_file_size_signal, output_lock
from lab.cli.sampling import add_design_flags, design_from_args
from lab.fem.bodies.mesh_spec import MeshSpec
from lab.jobs import simulate as job
from lab.jobs.simulate import CommandsSpec
from lab.workers import default_jobs

#: The sampling flags (DesignSpec's, and the design's seed), which ``--commands`` does not use.
_SAMPLING = ("grid", "sobol", "lhs", "design", "n", "active", "batch", "ensemble_members", "ensemble_hidden",
             "ensemble_epochs", "seed")  # fmt: skip


def add_parser(subparsers, parents=()) -> argparse.ArgumentParser:
    """Add this command to an ``argparse`` subparsers object; returns its parser."""
    s = subparsers.add_parser(
        "simulate", parents=parents, help="simulate (u, y) pairs of a robot with the FEM and write a dataset"
    )
    s.add_argument("--robot", default="three-cable", help="shipped robot name or path to a TOML description")
    add_design_flags(s)
    s.add_argument(
        "--seed", type=int, default=None, help="seed of the design (or of --active's picks and ensembles; default 0)"
    )
    add_spec_flags(s, CommandsSpec)
    add_spec_flags(
        s,
        MeshSpec,
        help={"n_rings": "override the description's mesh rings", "n_axial": "override the description's mesh layers"},
    )
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

    given = spec_from_args(CommandsSpec, args).commands
    if given is not None:  # a flag the mode does not use is refused
        refuse_unused(args, _SAMPLING, "with --commands: the file gives the commands and their order")
    if args.seed is None:
        args.seed = 0
    design, mesh = design_from_args(args), spec_from_args(MeshSpec, args)
    checkpoint = args.checkpoint or f"{args.out}.chunks"
    check_paths(
        {"--robot": existing(args.robot), **({"--commands": given} if given is not None else {})},
        # the lock file is written (and removed) too: it must not be an input either
        {**dataset_outputs("--out", args.out), "--out lock": f"{args.out}.lock", "--checkpoint": checkpoint},
    )
    check_writable(args.out)
    check_checkpoint(checkpoint, "--checkpoint")  # a checkpoint under a file fails now, not after the first chunk
    ignore_file_size_signal()  # a write past `ulimit -f` fails with EFBIG, reported as such
    robot = load_robot(args.robot)
    with output_lock(args.out):
        job.run(
            design,
            robot,
            mesh,
            args.out,
            checkpoint=checkpoint,
            command="python -m lab " + shlex.join(sys.argv[1:]),
            jobs=args.jobs,
            chunk_size=args.chunk_size,
            progress=not args.no_progress,
            scheduler=args.scheduler,
            restart=args.restart,
            commands=given,
        )
    return 0
