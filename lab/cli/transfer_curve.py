"""``python -m lab transfer-curve``: the sim-to-real curve over a family of emulated
as-built robots (:func:`lab.jobs.transfer_curve.run`, :mod:`lab.studies.transfer_study`).

For each robot (``--family K``: members 0..K-1 of :data:`lab.asbuilt.RANDOM`,
or with ``--family-kind foam`` of :data:`lab.asbuilt.FOAM`, rows labelled
``foam:K``; plus ``--shipped`` for the shipped defects file), each method and each N it writes one row:
model error on held-out random commands and Table I tracking errors, in metres. The flags
are :class:`lab.studies.transfer_curve.TransferCurveSpec`'s. Rows are appended robot by
robot, so an interrupted run resumes where it stopped; a robot whose rows are all there is
skipped. A run holds ``OUT.lock`` while it writes: a second run on the same ``--out`` is
refused at once (each rewrites the whole file, so two at a time would lose rows).
"""

from __future__ import annotations

import argparse
import shlex
import sys

from lab.cli.flags import add_spec_flags, spec_from_args
from lab.cli.paths import check_paths, check_writable, existing, output_lock
from lab.fem.bodies.mesh_spec import MeshSpec
from lab.jobs import transfer_curve as job
from lab.studies.transfer_curve import TransferCurveSpec
from lab.workers import default_jobs

MESH_HELP = {"n_rings": "the emulated robots' FEM mesh", "n_axial": "the emulated robots' FEM mesh"}
MESH_DEFAULT = {"n_rings": "the defects' or robot's", "n_axial": "the defects' or robot's"}


def add_parser(subparsers, parents=()) -> argparse.ArgumentParser:
    """Add this command to an ``argparse`` subparsers object; returns its parser."""
    t = subparsers.add_parser(
        "transfer-curve",
        parents=parents,
        help="error against the number of real samples, per transfer method, over a family of as-built robots",
    )
    add_spec_flags(t, TransferCurveSpec, default_words={"methods": "all but calibrated", "jobs": "all cores"})
    add_spec_flags(t, MeshSpec, help=MESH_HELP, default_words=MESH_DEFAULT)
    t.add_argument("--out", required=True, help="CSV, one row per (robot, method, N); resumed if it exists")
    t.set_defaults(func=run)
    return t


def run(args) -> int:
    jobs = {} if args.jobs is not None else {"jobs": default_jobs()}
    spec = spec_from_args(TransferCurveSpec, args, mesh=spec_from_args(MeshSpec, args), **jobs)
    inputs = {"--sim-model": existing(spec.sim_model)}
    if spec.robot.endswith(".toml"):
        inputs["--robot"] = existing(spec.robot)
    # the lock file is written (and removed) too: it must not be an input either
    check_paths(inputs, {"--out": args.out, "--out sidecar": f"{args.out}.json", "--out lock": f"{args.out}.lock"})
    check_writable(args.out)
    command = "python -m lab " + shlex.join(args.argv)
    with output_lock(args.out):  # a second run on this file is refused: it would drop the first's rows
        job.run(spec, args.out, command=command, log=lambda line: print(line, file=sys.stderr))
    return 0
