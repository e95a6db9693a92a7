"""``python -m lab calibrate``: identify the as-built FEM parameters from real samples and write
the calibrated robot as a description TOML that every command accepts as ``--robot``.

The real samples are a dataset from ``capture`` (any rig: ``twin``, ``twin:random:SEED``,
``hardware:RIG.toml``) or ``import-data``, with every marker it holds; the fit's flags are
:class:`lab.jobs.calibrate.CalibrationSpec`'s (``--fit GROUPS`` among them). The
identified parameters (softness, stiffness gradient, eyelet shifts, slack per cable, density) and
their standard deviations are comments at the top of the TOML; a JSON summary goes to
stdout (and to ``--report``), progress to stderr, ending with a line that says whether the
calibrated model explains the samples at the declared noise (``--noise-m``: a chi-square
test of the residual; the JSON's ``model_discrepancy``, ``discrepancy``, ``std_reported``).
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys

from lab.cli.flags import add_spec_flags, spec_from_args
from lab.cli.paths import check_paths, check_writable, existing
from lab.cli.progress import Progress, add_progress_flag
from lab.fem.bodies.mesh_spec import MeshSpec
from lab.jobs import calibrate as job
from lab.jobs.calibrate import CalibrationSpec, calibration_summary, discrepancy_line

MESH_HELP = {"n_rings": "mesh rings of the FEM fitted", "n_axial": "mesh layers of the FEM fitted"}


def add_parser(subparsers, parents=()) -> argparse.ArgumentParser:
    """Add this command to an ``argparse`` subparsers object; returns its parser."""
    c = subparsers.add_parser(
        "calibrate",
        parents=parents,
        help="identify the as-built FEM parameters from real samples; write a calibrated robot TOML",
        description="Fit softness, stiffness gradient, eyelet shifts and slack of each cable of the FEM "
        "(or the groups --fit names, density among them) to real (u, y) samples, every marker the data "
        "hold (Levenberg-Marquardt with exact FEM sensitivities and a prior towards "
        "the nominal robot) and write the calibrated robot description, usable as --robot everywhere.",
    )
    c.add_argument("real", metavar="REAL.csv", help="real dataset CSV (u0..,x,y,z), e.g. from `capture`")
    c.add_argument("--robot", default="three-cable", help="nominal robot: shipped name or description TOML")
    c.add_argument("--out", required=True, help="output robot description (.toml)")
    c.add_argument("--report", help="also write the JSON summary here")
    words = {"n_rings": "the description's", "n_axial": "the description's"}
    add_spec_flags(c, MeshSpec, help=MESH_HELP, default_words=words)
    add_spec_flags(c, CalibrationSpec)
    add_progress_flag(c)
    c.set_defaults(func=run)
    return c


def run(args) -> int:
    from lab.description import load_robot
    from lab.files import atomic_write_text, json_default
    from lab.transfer import write_calibrated_robot

    spec = spec_from_args(CalibrationSpec, args, mesh=spec_from_args(MeshSpec, args))
    check_paths(
        {"REAL.csv": args.real, "REAL.csv sidecar": f"{args.real}.json", "--robot": existing(args.robot)},
        {"--out": args.out, "--report": args.report},
    )
    check_writable(args.out)
    if args.report:
        check_writable(args.report, "--report")
    robot = load_robot(args.robot)
    with Progress("iteration", enabled=not args.no_progress, at_most=True) as progress:
        result = job.run(spec, robot, args.real, log=progress.write, progress=progress.update)
    command = "python -m lab " + shlex.join(args.argv)
    write_calibrated_robot(args.out, robot, result, source=str(args.real), command=command)
    text = json.dumps(calibration_summary(robot, result, args.real, args.out, command), indent=2, default=json_default)
    if args.report:
        atomic_write_text(args.report, text + "\n")
    print(
        f"RMS tip misfit {1e3 * result.rms_nominal_m:.3f} mm (nominal) -> {1e3 * result.rms_m:.3f} mm in "
        f"{result.iterations} iterations, {result.wall_s:.1f} s; calibrated robot -> {args.out}",
        file=sys.stderr,
    )
    print(discrepancy_line(result), file=sys.stderr)
    print(text)
    return 0
