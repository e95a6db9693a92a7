"""``python -m lab fit-dynamics``: learn the foam's relaxation filter of a rig from step
responses and short random motions.

The rig is driven through the excitation of :mod:`lab.rig.dynamics_probe` while the motion
capture is recorded (:class:`~lab.rig.recorder.StreamRecorder`); ``K`` relaxation modes
(time constants and weights) and every command's equilibrium are fitted to the recording
(:func:`lab.learn.relaxation_fit.fit_stream`), and the filter is written as ``DYN.npz``
(:meth:`lab.learn.relaxation.Relaxation.save`, kind ``lab.dynamics``) with the robot, the
rig's description, the plan, the command line and the fit's RMS residual in its metadata.
``track --period-s T --dynamic-model DYN.npz`` inverts it into a feed-forward command.
Exit codes: 2 for bad input, 1 when the rig fails.
"""

from __future__ import annotations

import argparse
import shlex
import sys

from lab.cli.paths import check_paths, check_writable, existing
from lab.errors import InputError


def add_parser(subparsers, parents=()) -> argparse.ArgumentParser:
    """Add this command to an ``argparse`` subparsers object; returns its parser."""
    c = subparsers.add_parser(
        "fit-dynamics",
        parents=parents,
        help="learn a rig's dynamic model (the foam's relaxation) from step responses and random motions",
        description="Drive the rig through step responses (long holds) and short random motions, record "
        "the motion capture, and fit K first-order relaxation modes of the tip toward its quasi-static "
        "equilibrium; writes DYN.npz for track --period-s T --dynamic-model DYN.npz.",
    )
    c.add_argument(
        "--rig",
        default="twin",
        help="twin[:DEFECTS.toml] | twin:random:SEED | hardware:CONFIG.toml (default twin; "
        "sim has no dynamics to learn)",
    )
    c.add_argument("--robot", default="three-cable", help="shipped robot name or path to a TOML description")
    c.add_argument("--out", required=True, help="output dynamic model (.npz)")
    c.add_argument("--seed", type=int, default=0, help="seed of the random commands (and of an emulated rig's noise)")
    c.add_argument("--n-steps", type=int, default=6, help="step responses, each held --step-hold-s (default 6)")
    c.add_argument("--n-random", type=int, default=40, help="random commands held 0.3-1.5 s each (default 40)")
    c.add_argument("--modes", type=int, default=2, help="relaxation modes K to fit (default 2)")
    c.add_argument(
        "--step-hold-s",
        type=float,
        default=10.0,
        help="hold of each step response, s: about four times the slowest time constant (default 10)",
    )
    c.add_argument("--n-rings", type=int, help="FEM mesh rings of an emulated twin (default: its own)")
    c.add_argument("--n-axial", type=int, help="FEM mesh layers of an emulated twin (default: its own)")
    c.set_defaults(func=run)
    return c


def make_dynamic_rig(spec: str, robot, seed: int = 0, n_rings: int | None = None, n_axial: int | None = None):
    """The rig of ``--rig spec`` (:func:`lab.rig.make_rig`), with the FEM mesh of an emulated
    twin set by ``n_rings``/``n_axial`` (coarse meshes for quick runs); ``sim`` is refused:
    the quasi-static FEM has no dynamics."""
    from lab.rig import make_rig
    from lab.rig.family import FamilyTwinRig, parse_robot_seed
    from lab.rig.twin import AsBuiltBody, TwinRig

    kind, _, arg = str(spec).partition(":")
    if kind == "sim":
        raise InputError("--rig sim is the quasi-static FEM: it has no dynamics to learn or stream")
    mesh = {k: v for k, v in (("n_rings", n_rings), ("n_axial", n_axial)) if v is not None}
    for flag, v in mesh.items():
        if v < 1:
            raise InputError(f"--{flag.replace('_', '-')} must be a positive integer, got {v}")
    if not mesh:
        return make_rig(spec, robot, seed=seed)
    if kind != "twin":
        raise InputError("--n-rings/--n-axial set the FEM mesh of an emulated twin only")
    if arg == "random" or arg.startswith("random:"):
        return FamilyTwinRig(robot, parse_robot_seed(arg.partition(":")[2], spec), seed=seed, **mesh)
    return TwinRig(robot, seed=seed, body=AsBuiltBody(robot, arg or None, **mesh))


def run(args) -> int:
    """``python -m lab fit-dynamics``; returns the exit code."""
    import numpy as np

    from lab.description import load_robot
    from lab.learn.relaxation_fit import fit_stream
    from lab.rig.dynamics_probe import plan_info, probe_plan, run_probe

    rig_file = args.rig.partition(":")[2] or None
    check_paths({"--robot": existing(args.robot), "--rig": existing(rig_file)}, {"--out": args.out})
    check_writable(args.out)
    if not str(args.out).endswith(".npz"):
        raise InputError(f"--out {args.out}: a dynamic model is written as .npz")
    for flag, v, lo in (("--n-steps", args.n_steps, 1), ("--n-random", args.n_random, 0), ("--modes", args.modes, 1)):
        if v < lo:
            raise InputError(f"{flag} must be an integer >= {lo}, got {v}")
    if args.modes > 4:
        raise InputError(f"--modes {args.modes}: at most 4 relaxation modes can be told apart")
    if not (np.isfinite(args.step_hold_s) and args.step_hold_s > 0):
        raise InputError(f"--step-hold-s must be a positive number of seconds, got {args.step_hold_s}")
    robot = load_robot(args.robot)
    plan = probe_plan(robot, args.seed, args.n_steps, args.n_random, args.step_hold_s)
    print(
        f"{robot.name} on {args.rig}: {args.n_steps} steps held {args.step_hold_s:g} s and {args.n_random} "
        f"random motions, {plan.duration_s:.0f} s of holds",
        file=sys.stderr,
    )
    with make_dynamic_rig(args.rig, robot, args.seed, args.n_rings, args.n_axial) as rig:
        describe = rig.describe()
        stream = run_probe(rig, plan)
    relax, report = fit_stream(stream, args.modes)
    command = "python -m lab " + shlex.join(getattr(args, "argv", sys.argv[1:]))
    relax.save(
        args.out,
        robot=robot.name,
        robot_sha256=robot.sha256,
        rig=describe,
        plan=plan_info(plan),
        fit={"rms_m": report["rms_m"], "n_readings": report["n_readings"], "n_poses": len(report["equilibria"])},
        command=command,
    )
    modes = ", ".join(f"tau {t:.3f} s weight {w:.3f}" for t, w in zip(relax.tau_s, relax.weight))
    print(
        f"{args.modes} modes: {modes}; fit RMS {1e3 * report['rms_m']:.3f} mm over {report['n_readings']} "
        f"readings, noise {1e3 * relax.noise_sigma_m:.3f} mm per frame -> {args.out}",
        file=sys.stderr,
    )
    return 0
