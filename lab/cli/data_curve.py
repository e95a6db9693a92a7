"""``python -m lab data-curve``: model and tracking error against the number of samples N,
per sampling strategy (:func:`lab.jobs.data_curve.run`, :mod:`lab.studies.data_curve`).

For one robot on one rig (``sim``: the nominal FEM; ``twin``, ``twin:DEFECTS.toml``,
``twin:random:SEED``, ``twin:foam:SEED``: an emulated as-built robot), each strategy and each N it writes one
row: the model error on a common held-out set of random allowed commands, the Table I
tracking errors (unless ``--no-tracking``), the fit time and the capture hours at the
measured rate. The flags are :class:`lab.studies.data_curve_spec.DataCurveSpec`'s. Rows are
appended one by one, so an interrupted run resumes where it stopped; a (strategy, N, seed)
already in the file is never measured again, and a file is only resumed with the settings
it was made with. One run at a time writes an ``--out`` (a second is refused at once).
"""

from __future__ import annotations

import argparse
import shlex
import sys

from lab.cli.flags import add_spec_flags, spec_from_args
from lab.cli.paths import check_paths, check_writable, existing, output_lock
from lab.fem.bodies.mesh_spec import MeshSpec
from lab.jobs import data_curve as job
from lab.studies.data_curve_spec import DataCurveSpec
from lab.workers import default_jobs

DEFAULT_WORDS = {
    "strategies": "all but active that this install has",
    "grid_levels": "the safe count nearest each N",
    "epochs": "the trainer's",
    "n_initial": "max(2 batch, 10 motors)",
    "samples_per_hour": "--rate-from's",
}
MESH_HELP = {"n_rings": "the FEM mesh of the robot", "n_axial": "the FEM mesh of the robot"}
MESH_DEFAULT = {"n_rings": "the description's", "n_axial": "the description's"}


def add_parser(subparsers, parents=()) -> argparse.ArgumentParser:
    """Add this command to an ``argparse`` subparsers object; returns its parser."""
    p = subparsers.add_parser(
        "data-curve",
        parents=parents,
        help="model and tracking error against the number of samples, per sampling strategy",
    )
    add_spec_flags(p, DataCurveSpec, default_words=DEFAULT_WORDS)
    add_spec_flags(p, MeshSpec, help=MESH_HELP, default_words=MESH_DEFAULT)
    p.add_argument("--jobs", type=int, default=default_jobs(), help="worker processes, one row each")
    p.add_argument("--out", required=True, help="CSV, one row per (strategy, N, seed); resumed if it exists")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    spec = spec_from_args(DataCurveSpec, args, mesh=spec_from_args(MeshSpec, args))
    inputs = {"--robot": existing(spec.robot) if spec.robot.endswith(".toml") else None}
    # the lock file is written (and removed) too: it must not be an input either
    check_paths(inputs, {"--out": args.out, "--out sidecar": f"{args.out}.json", "--out lock": f"{args.out}.lock"})
    check_writable(args.out)
    command = "python -m lab " + shlex.join(args.argv)
    with output_lock(args.out):
        job.run(spec, args.out, jobs=args.jobs, command=command, log=lambda line: print(line, file=sys.stderr))
    return 0
