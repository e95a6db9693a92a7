"""``python -m lab track --period-s T [--dynamic-model DYN.npz]``: stream a trajectory at speed.

Called by :mod:`lab.cli.track` when ``--period-s`` is given: the trajectory is one period of
``T`` seconds, commanded continuously (:func:`lab.tracking.stream.stream_trajectory`) --
quasi-static open loop, or pre-compensated by the inverse of the dynamic model that
``python -m lab fit-dynamics`` learned. The result file is a track result
(:mod:`lab.tracking.track`) with the streamed keys of :mod:`lab.tracking.stream`.
With ``--period-s``, ``--n-rings``/``--n-axial`` also set the mesh of an emulated twin.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

import numpy as np

from lab.cli.paths import check_paths, check_writable, existing
from lab.errors import InputError


def add_stream_arguments(parser: argparse.ArgumentParser) -> None:
    """The streaming flags of ``track`` (one block)."""
    parser.add_argument(
        "--period-s",
        type=float,
        default=None,
        help="stream the trajectory continuously as one period of this many seconds (2-20 s typical) "
        "instead of settling at each point; error over the last period (default: settle at each point)",
    )
    parser.add_argument(
        "--dynamic-model",
        default=None,
        help="with --period-s: the dynamic model DYN.npz of `fit-dynamics`, inverted into a feed-forward "
        "pre-compensation of the commands (default: quasi-static open loop)",
    )
    parser.add_argument(
        "--n-periods",
        type=int,
        default=None,
        help="with --period-s: periods streamed (default: enough for 8 s of motion before the last, >= 2)",
    )
    parser.add_argument(
        "--lead-in-s", type=float, default=None, help="with --period-s: settle at the first command first, s (10)"
    )
    parser.add_argument(
        "--command-rate-hz", type=float, default=None, help="with --period-s: commands per second (default 20)"
    )


def check_stream_flags(args) -> bool:
    """Whether this is a streamed run; InputError for streaming flags without ``--period-s``
    or flags a streamed run cannot honour."""
    extra = {
        "--dynamic-model": args.dynamic_model,
        "--n-periods": args.n_periods,
        "--lead-in-s": args.lead_in_s,
        "--command-rate-hz": args.command_rate_hz,
    }
    if args.period_s is None:
        given = [flag for flag, v in extra.items() if v is not None]
        if given:
            raise InputError(f"{', '.join(given)} need --period-s T")
        return False
    if getattr(args, "closed_loop", None) is not None:
        raise InputError("--period-s streams open loop or feed-forward; it does not combine with --closed-loop")
    if not (np.isfinite(args.period_s) and 0.5 <= args.period_s <= 600):
        raise InputError(f"--period-s must be a period in [0.5, 600] s, got {args.period_s}")
    if args.n_periods is not None and args.n_periods < 1:
        raise InputError(f"--n-periods must be an integer >= 1, got {args.n_periods}")
    if args.lead_in_s is not None and not (np.isfinite(args.lead_in_s) and args.lead_in_s >= 0):
        raise InputError(f"--lead-in-s must be a non-negative number of seconds, got {args.lead_in_s}")
    rate = args.command_rate_hz
    if rate is not None and not (np.isfinite(rate) and 1 <= rate <= 200):
        raise InputError(f"--command-rate-hz must lie in [1, 200], got {rate}")
    return True


def run_streamed(args) -> int:
    """The streamed ``track`` run; returns the exit code."""
    from lab.cli.fit_dynamics import make_dynamic_rig
    from lab.control.trajectories import BUILTIN, SIX_CABLE, load_trajectory
    from lab.description import load_robot
    from lab.fem.energy import ArmFEM
    from lab.learn.models import load_model
    from lab.learn.relaxation import load_relaxation
    from lab.rig import make_rig
    from lab.rig.sim import SimRig
    from lab.tracking.stream import DEFAULT_COMMAND_RATE_HZ, DEFAULT_LEAD_IN_S, stream_trajectory
    from lab.tracking.track import make_solver, write_result

    if (args.model is None) == (not args.soft_ik):
        raise InputError("give exactly one of --model MODEL.npz and --soft-ik")
    rig_file = args.rig.partition(":")[2] or None
    check_paths(
        {
            "--model": args.model,
            "--dynamic-model": args.dynamic_model,
            "--trajectory": existing(args.trajectory),
            "--robot": existing(args.robot),
            "--rig": existing(rig_file),
        },
        {"--out": args.out},
    )
    check_writable(args.out)
    robot = load_robot(args.robot)
    targets = load_trajectory(args.trajectory, args.n_points)
    relax = None if args.dynamic_model is None else load_relaxation(args.dynamic_model)
    mesh = {"n_rings": args.n_rings, "n_axial": args.n_axial}
    fem = ArmFEM(robot, **mesh) if (args.rig == "sim" or args.soft_ik) else None
    model = None if args.soft_ik else load_model(args.model)
    solver = make_solver(robot, model, fem=fem if args.soft_ik else None, method=args.solver)
    for note in solver.notes:
        print(f"IK: {note}", file=sys.stderr)
    name = args.trajectory if args.trajectory in BUILTIN + SIX_CABLE else Path(args.trajectory).name
    rate = DEFAULT_COMMAND_RATE_HZ if args.command_rate_hz is None else args.command_rate_hz
    lead_in = DEFAULT_LEAD_IN_S if args.lead_in_s is None else args.lead_in_s
    if args.rig == "sim":
        rig = SimRig(robot, fem)
    elif args.rig.startswith("twin"):
        rig = make_dynamic_rig(args.rig, robot, args.seed, **mesh)
    else:
        if any(v is not None for v in mesh.values()) and not args.soft_ik:
            raise InputError("--n-rings/--n-axial set the FEM mesh of --rig sim, an emulated twin and --soft-ik only")
        rig = make_rig(args.rig, robot, seed=args.seed)
    with rig:
        result = stream_trajectory(
            rig, solver, targets, args.period_s, relax=relax, n_periods=args.n_periods, command_rate_hz=rate,
            lead_in_s=lead_in, name=name,
        )  # fmt: skip
    write_result(
        args.out,
        result,
        {
            "model": args.model,
            "soft_ik": bool(args.soft_ik),
            "dynamic_model_path": args.dynamic_model,
            "command": "python -m lab " + shlex.join(getattr(args, "argv", sys.argv[1:])),
        },
    )
    print(
        f"{name} streamed at T = {args.period_s:g} s ({result.mode}, {result.n_periods} periods, "
        f"{rate:g} commands/s): mean error {100 * result.mean_error_m:.4f} cm, max "
        f"{100 * result.max_error_m:.4f} cm over the last period's {len(result.errors_m)} frames; "
        f"{int(np.sum(~result.knots.reachable))} equilibria out of reach, motors up to "
        f"{result.knots.max_motor_speed_rad_s:.2f} rad/s -> {args.out}",
        file=sys.stderr,
    )
    return 0
