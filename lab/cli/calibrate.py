"""``python -m lab calibrate``: identify the as-built FEM parameters from real samples and write
the calibrated robot as a description TOML that every command accepts as ``--robot``.

The real samples are a dataset from ``capture`` (any rig: ``twin``, ``twin:random:SEED``,
``hardware:RIG.toml``). The identified parameters (softness, stiffness gradient, eyelet
shifts, slack per cable) and their standard deviations are comments at the top of the
TOML; a JSON summary goes to stdout (and to ``--report``), progress to stderr.
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys

from lab.cli.paths import check_paths, check_writable, existing
from lab.errors import InputError, LabRuntimeError


def add_parser(subparsers, parents=()) -> argparse.ArgumentParser:
    """Add this command to an ``argparse`` subparsers object; returns its parser."""
    c = subparsers.add_parser(
        "calibrate",
        parents=parents,
        help="identify the as-built FEM parameters from real samples; write a calibrated robot TOML",
        description="Fit softness, stiffness gradient, eyelet shifts and slack of each cable of the FEM "
        "to real (u, y) samples (Levenberg-Marquardt with exact FEM sensitivities and a prior towards "
        "the nominal robot) and write the calibrated robot description, usable as --robot everywhere.",
    )
    c.add_argument("real", metavar="REAL.csv", help="real dataset CSV (u0..,x,y,z), e.g. from `capture`")
    c.add_argument("--robot", default="three-cable", help="nominal robot: shipped name or description TOML")
    c.add_argument("--out", required=True, help="output robot description (.toml)")
    c.add_argument("--report", help="also write the JSON summary here")
    c.add_argument("--n-rings", type=int, help="mesh rings of the FEM fitted (default: the description's)")
    c.add_argument("--n-axial", type=int, help="mesh layers of the FEM fitted (default: the description's)")
    c.add_argument(
        "--noise-m",
        type=float,
        default=5e-4,
        help="tip error per coordinate the fit expects, m: mocap noise plus what the static FEM cannot "
        "model; weighs the data against the prior (default 5e-4)",
    )
    c.add_argument(
        "--axes", choices=["yz", "xyz"], default="yz", help="eyelet-shift components identified (default yz)"
    )
    c.add_argument("--max-iter", type=int, default=30, help="Levenberg-Marquardt iterations at most (default 30)")
    c.set_defaults(func=run)
    return c


def run(args) -> int:
    from lab.data.dataset import read_dataset
    from lab.description import load_robot
    from lab.fem.mesh import check_mesh_size
    from lab.files import atomic_write_text, code_version, json_default
    from lab.transfer import calibrate, write_calibrated_robot

    check_paths(
        {"REAL.csv": args.real, "REAL.csv sidecar": f"{args.real}.json", "--robot": existing(args.robot)},
        {"--out": args.out, "--report": args.report},
    )
    check_writable(args.out)
    if args.report:
        check_writable(args.report, "--report")
    for flag, v in (("--n-rings", args.n_rings), ("--n-axial", args.n_axial), ("--max-iter", args.max_iter)):
        if v is not None and v < 1:
            raise InputError(f"{flag} must be positive, got {v}")
    if not args.noise_m > 0:
        raise InputError(f"--noise-m must be a positive length in m, got {args.noise_m}")
    robot = load_robot(args.robot)
    n_rings = robot.n_rings if args.n_rings is None else args.n_rings
    n_axial = robot.n_axial if args.n_axial is None else args.n_axial
    check_mesh_size(n_rings, n_axial)
    u, y, meta = read_dataset(args.real)
    name = (meta.get("robot") or {}).get("name")
    if name is not None and name != robot.name:
        raise InputError(f"REAL.csv {args.real} was captured on robot {name!r}, but --robot is {robot.name!r}")
    if u.shape[1] != robot.n_cables:
        raise InputError(f"{args.real}: {u.shape[1]} motor columns, but {robot.name} has {robot.n_cables} cables")
    print(
        f"{robot.name}: calibrating on {len(u)} real samples from {args.real}, mesh n_rings={n_rings} "
        f"n_axial={n_axial}, eyelet shifts in {args.axes}",
        file=sys.stderr,
    )
    try:
        result = calibrate(
            robot,
            u,
            y,
            n_rings=n_rings,
            n_axial=n_axial,
            axes=args.axes,
            noise_m=args.noise_m,
            max_iter=args.max_iter,
            log=lambda line: print(line, file=sys.stderr),
        )
    except InputError as err:
        raise InputError(f"{args.real}: {err}") from None
    if not result.converged:
        raise LabRuntimeError(
            f"calibration did not converge in {result.iterations} iterations (RMS tip misfit "
            f"{1e3 * result.rms_m:.3f} mm); nothing written: raise --max-iter, or check the data"
        )
    command = "python -m lab " + shlex.join(args.argv)
    write_calibrated_robot(args.out, robot, result, source=str(args.real), command=command)
    summary = {
        "kind": "lab.calibration",
        "format_version": 1,
        "robot": robot.name,
        "real": str(args.real),
        "out": str(args.out),
        **result.summary(),
        "command": command,
        "code_version": code_version(),
    }
    text = json.dumps(summary, indent=2, default=json_default)
    if args.report:
        atomic_write_text(args.report, text + "\n")
    print(
        f"RMS tip misfit {1e3 * result.rms_nominal_m:.3f} mm (nominal) -> {1e3 * result.rms_m:.3f} mm in "
        f"{result.iterations} iterations, {result.wall_s:.1f} s; calibrated robot -> {args.out}",
        file=sys.stderr,
    )
    print(text)
    return 0
