"""``python -m lab track``: follow a trajectory on a rig with IK through a model, or Soft IK.

The result file is described in :mod:`lab.tracking.track`. ``--closed-loop ilc|feedback
--passes K [--gain A]`` corrects the commands from the measured tip through the model's
Jacobian (:mod:`lab.tracking.closed_loop`) and adds ``passes`` to the file.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

import numpy as np

from lab.cli.paths import check_paths, check_writable, existing
from lab.cli.track_stream import add_stream_arguments, check_stream_flags, run_streamed
from lab.errors import InputError
from lab.tracking.closed_loop import run_closed_loop
from lab.tracking.track import PointLog, make_solver, run_trajectory, write_result


def add_parser(subparsers, parents=()) -> argparse.ArgumentParser:
    """Add this command to an ``argparse`` subparsers object; returns its parser."""
    k = subparsers.add_parser(
        "track", parents=parents, help="follow a trajectory on a rig with IK through a model (or Soft IK)"
    )
    src = k.add_mutually_exclusive_group(required=True)
    src.add_argument("--model", help="learned forward model (.npz) to solve the IK through")
    src.add_argument("--soft-ik", action="store_true", help="Soft IK: solve the IK through the FEM instead")
    k.add_argument(
        "--rig",
        default="sim",
        help="sim | twin[:DEFECTS.toml] | twin:random:SEED (an emulated as-built robot of the family) "
        "| hardware:CONFIG.toml (default sim)",
    )
    k.add_argument("--robot", default="three-cable", help="shipped robot name or path to a TOML description")
    k.add_argument(
        "--trajectory",
        required=True,
        help="circle, square, rose, helix (three-cable), six-circle, six-ring, six-saddle, six-spiral "
        "(six-cable), or a CSV file with header x,y,z (metres, frame W)",
    )
    k.add_argument("--n-points", type=int, help="points of a built-in trajectory (default: its own)")
    k.add_argument(
        "--solver",
        choices=["lm", "gd", "dfo"],
        default=None,
        help="bounded Levenberg-Marquardt, projected gradient descent, or derivative-free IK (secant LM "
        "steps and a compass poll; default: lm, or dfo for a model without a Jacobian)",
    )
    k.add_argument(
        "--reg-weight",
        type=float,
        default=None,
        help="regulariser towards the previous command on every point, m^2/rad^2 (default auto: none; "
        "on a redundant arm a missed target is solved again from the posture, regularised with a "
        "thousandth of the model's mean squared Jacobian column, and polished; 0 is off)",
    )
    k.add_argument(
        "--posture-weight",
        type=float,
        default=None,
        help="regulariser towards the centre of the allowed commands (keeps a redundant "
        "arm's cables taut) on every point, m^2/rad^2 (default auto, as --reg-weight); regularised answers "
        "are polished",
    )
    k.add_argument(
        "--spread-weight",
        type=float,
        default=0.0,
        help="penalise the model ensemble's spread at the command (dimensionless weight on its "
        "variance, m^2 per m^2 of tip error; needs an ensemble model; default 0: off)",
    )
    k.add_argument(
        "--max-spread-mm",
        type=float,
        default=None,
        help="flag a target 'uncertain' where the model's predicted spread exceeds this, mm "
        "(default 1 mm for a model with a spread; never for one without)",
    )
    k.add_argument(
        "--closed-loop",
        choices=["ilc", "feedback"],
        default=None,
        help="correct the commands from the measured tip through the model's Jacobian: ilc = iterative "
        "learning control over repeated passes of the whole trajectory; feedback = settle, measure, "
        "correct at each target (default: open loop)",
    )
    k.add_argument(
        "--passes",
        type=int,
        default=None,
        help="with --closed-loop: runs including the open-loop pass 0 (ilc), or measurements per "
        "target (feedback); default 3",
    )
    k.add_argument(
        "--gain",
        type=float,
        default=None,
        help="with --closed-loop: correction gain alpha in (0, 2) (default 0.9)",
    )
    # Trajectories at speed: --period-s, --dynamic-model, ... (lab.cli.track_stream)
    add_stream_arguments(k)
    k.add_argument("--seed", type=int, default=0, help="noise seed of an emulated rig")
    k.add_argument("--n-rings", type=int, help="FEM mesh rings of --rig sim / --soft-ik (default: robot's)")
    k.add_argument("--n-axial", type=int, help="FEM mesh layers of --rig sim / --soft-ik (default: robot's)")
    k.add_argument("--out", required=True, help="result JSON")
    k.set_defaults(func=run)

    return k


def run(args) -> int:
    """``python -m lab track``: see :func:`lab.cli.build_parser`. Returns the exit code."""
    from lab.control.trajectories import BUILTIN, SIX_CABLE, load_trajectory
    from lab.description import load_robot
    from lab.fem.energy import ArmFEM
    from lab.learn.models import load_model
    from lab.rig import make_rig
    from lab.rig.sim import SimRig

    if check_stream_flags(args):  # --period-s: streamed at speed (lab.cli.track_stream)
        return run_streamed(args)
    if (args.model is None) == (not args.soft_ik):
        raise InputError("give exactly one of --model MODEL.npz and --soft-ik")
    correction = _correction(args)
    points = Path(f"{args.out}.points.csv")
    rig_file = args.rig.partition(":")[2] or None
    check_paths(
        {
            "--model": args.model,
            "--trajectory": existing(args.trajectory),
            "--robot": existing(args.robot),
            "--rig": existing(rig_file),
        },
        {"--out": args.out, "--out points": points},
    )
    check_writable(args.out)
    robot = load_robot(args.robot)
    targets = load_trajectory(args.trajectory, args.n_points)
    mesh = {"n_rings": args.n_rings, "n_axial": args.n_axial}
    custom_mesh = any(v is not None for v in mesh.values())
    if custom_mesh and args.rig != "sim" and not args.soft_ik:
        raise InputError("--n-rings/--n-axial set the FEM mesh of --rig sim and --soft-ik only")
    fem = ArmFEM(robot, **mesh) if (args.rig == "sim" or args.soft_ik) else None
    model = None if args.soft_ik else load_model(args.model)
    if args.max_spread_mm is not None and not (args.max_spread_mm > 0 and np.isfinite(args.max_spread_mm)):
        raise InputError(f"--max-spread-mm must be a positive number of mm, got {args.max_spread_mm}")
    solver = make_solver(
        robot,
        model,
        fem=fem if args.soft_ik else None,
        method=args.solver,
        reg_weight=args.reg_weight,
        posture_weight=args.posture_weight,
        spread_weight=args.spread_weight,
        max_spread_m=None if args.max_spread_mm is None else 1e-3 * args.max_spread_mm,
    )
    for note in solver.notes:
        print(f"IK: {note}", file=sys.stderr)
    name = args.trajectory if args.trajectory in BUILTIN + SIX_CABLE else Path(args.trajectory).name
    # Each measured point goes to OUT.points.csv at once: a run that is interrupted or fails
    # (a RigError, exit 1, reaches lab.cli.main after the rig was closed: torque off) keeps them.
    log = PointLog(points, robot.n_cables)
    try:
        with SimRig(robot, fem) if args.rig == "sim" else make_rig(args.rig, robot, seed=args.seed) as rig:
            if correction is None:
                result = run_trajectory(rig, solver, targets, name=name, on_point=log.append)
            else:
                result = run_closed_loop(
                    rig,
                    solver,
                    targets,
                    mode=args.closed_loop,
                    passes=args.passes,
                    correction=correction,
                    name=name,
                    on_point=log.append,
                )
    except BaseException:
        log.close()
        if log.n_points:
            print(f"(the {log.n_points} points measured so far are in {points})", file=sys.stderr)
        else:
            points.unlink()
        raise
    log.close()
    write_result(
        args.out,
        result,
        {
            "model": args.model,
            "soft_ik": bool(args.soft_ik),
            "command": "python -m lab " + shlex.join(getattr(args, "argv", sys.argv[1:])),
        },
    )
    points.unlink()  # the result file holds every point now
    t, sol = result.timings, result.info["solver"]
    for p in result.passes or ():
        print(
            f"{args.closed_loop} pass {p['pass']}: mean error {100 * p['mean_error_m']:.4f} cm, max "
            f"{100 * p['max_error_m']:.4f} cm"
            + (f", {p['n_skipped']} corrections skipped (too few valid frames)" if p["n_skipped"] else ""),
            file=sys.stderr,
        )
    uncertain = f", {int(np.sum(result.uncertain))} uncertain" if sol["max_spread_m"] is not None else ""
    print(
        f"{name}: {len(targets)} targets, mean error {100 * result.mean_error_m:.4f} cm, max "
        f"{100 * result.max_error_m:.4f} cm, {int(np.sum(~result.reachable))} unreachable{uncertain}; IK "
        f"({sol['method']}) {1e3 * t['ik_per_target_mean_s']:.2f} ms per target -> {args.out}",
        file=sys.stderr,
    )
    if sol["redundant"] or sol["reg_weight"] or sol["posture_weight"] or sol["ik"]["restarts"]:
        print(
            f"IK regularisation: {sol['regularisation']}; {sol['ik']['restarts']} points restarted, "
            f"{sol['ik']['recovered']} of them reached",
            file=sys.stderr,
        )
    return 0


def _correction(args):
    """The closed-loop settings from the flags (None: open loop); InputError for bad values."""
    from lab.tracking.closed_loop import DEFAULT_GAIN, Correction

    if args.closed_loop is None:
        if args.passes is not None or args.gain is not None:
            raise InputError("--passes and --gain need --closed-loop ilc|feedback")
        return None
    if args.passes is None:
        args.passes = 3
    if args.passes < 1:
        raise InputError(f"--passes must be an integer >= 1, got {args.passes}")
    gain = DEFAULT_GAIN if args.gain is None else args.gain
    if not (0 < gain < 2):
        raise InputError(f"--gain must lie in (0, 2), got {gain}")
    return Correction(gain=gain)
