"""``python -m lab track``: follow a trajectory on a rig with IK through a model, or Soft IK.

Open loop, closed loop (``--closed-loop ilc|feedback --passes K [--gain A]``) or streamed at
a period (``--period-s T [--dynamic-model DYN.npz]``); or ``--rig none``: no rig, the IK's
commands written to ``OUT.commands.csv`` for a lab's own robot (the ``--out`` name with
``.commands.csv`` appended, as ``OUT.points.csv`` and ``OUT.lock``; a file of that name it
did not write is refused). The flags become one
:class:`lab.jobs.track.TrackSpec`, each declared on the spec that takes it; a flag the chosen
mode does not use is refused. The run is :func:`lab.jobs.track.run`, with ``--out``
locked against a second run; the result file's keys are listed in docs/design/tracking.md.
Exit codes: 2 for bad input, 1 when the rig fails (measured points kept in OUT.points.csv).
"""

from __future__ import annotations

import argparse
import shlex
import sys

import numpy as np

from lab.cli.flags import add_spec_flags, flag_dest, flag_text, refuse_unused, spec_from_args
from lab.cli.paths import check_paths, check_writable, existing, output_lock
from lab.control.ik import IKConfig
from lab.fem.bodies.mesh_spec import MeshSpec
from lab.jobs import track as job
from lab.jobs.track import NO_RIG_UNUSED, TrackSpec
from lab.rig import RigSpec
from lab.tracking.closed_loop import Correction
from lab.tracking.solved_targets import commands_path
from lab.tracking.stream_spec import StreamSpec

#: The IK settings ``track`` has flags for (the rest keep :meth:`IKConfig.automatic`'s values).
TRACK_IK_FIELDS = ("method", "reg_weight", "posture_weight", "spread_weight", "markers")
#: Flags (argparse names) that only a settled run uses, only a streamed one, only a closed loop,
#: and those about a model's spread.
SETTLED_ONLY = ("reg_weight", "posture_weight", "spread_weight", "max_spread_mm", "closed_loop", "passes", "gain")
STREAMED_ONLY = ("dynamic_model", "n_periods", "lead_in_s", "command_rate_hz")
CLOSED_LOOP_ONLY = ("passes", "gain")
SPREAD_ONLY = ("spread_weight", "max_spread_mm")


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
        help="sim | twin[:DEFECTS.toml] | twin:random:SEED | twin:foam:SEED (an emulated as-built robot of a family) "
        "| hardware:CONFIG.toml | none (no rig: solve the IK through --model within its training data's "
        "commands and write them to OUT.commands.csv, for your own robot; the IK residual through the model "
        "it reports is not an accuracy: nothing is measured) (default sim)",
    )
    k.add_argument(
        "--robot", help="shipped robot name or path to a TOML description (default three-cable; not with --rig none)"
    )
    add_spec_flags(k, TrackSpec, only=("trajectory", "n_points"))
    # the IK's settings: --solver, --reg-weight, --posture-weight, --spread-weight (lab.control.ik_config)
    add_spec_flags(k, IKConfig, only=TRACK_IK_FIELDS, base=IKConfig.automatic())
    add_spec_flags(k, TrackSpec, only=("max_spread_mm",))
    add_spec_flags(k, TrackSpec, only=("closed_loop", "passes"))
    add_spec_flags(k, Correction, only=("gain",))
    # trajectories at speed: --period-s, --dynamic-model, ... (lab.tracking.stream)
    add_spec_flags(k, StreamSpec, only=("period_s",))
    add_spec_flags(k, TrackSpec, only=("dynamic_model",))
    add_spec_flags(k, StreamSpec, only=("n_periods", "lead_in_s", "command_rate_hz"))
    k.add_argument("--seed", type=int, help="noise seed of an emulated rig (default 0)")
    add_spec_flags(
        k,
        MeshSpec,
        help={
            "n_rings": "FEM mesh rings of --rig sim / --soft-ik (and of an emulated twin with --period-s)",
            "n_axial": "FEM mesh layers of --rig sim / --soft-ik (and of an emulated twin with --period-s)",
        },
        default_words={"n_rings": "robot's", "n_axial": "robot's"},
    )
    k.add_argument(
        "--out",
        required=True,
        help="result JSON (with --rig none also OUT.commands.csv, the name with .commands.csv appended: "
        "--out plan.json writes plan.json.commands.csv)",
    )
    k.set_defaults(func=run)
    return k


def run(args) -> int:
    """``python -m lab track``: see :func:`lab.cli.build_parser`. Returns the exit code."""
    spec = track_spec(args)
    points = None if spec.stream is not None or not spec.rig.has_rig else f"{args.out}.points.csv"
    commands = None if spec.rig.has_rig else commands_path(args.out)
    check_paths(
        {
            "--model": args.model,
            "--dynamic-model": args.dynamic_model,
            "--trajectory": existing(args.trajectory),
            "--robot": existing(args.robot),
            "--rig": existing(spec.rig.file),
        },
        {"--out": args.out, "--out points": points, "--out commands": commands, "--out lock": f"{args.out}.lock"},
    )
    check_writable(args.out)
    command = "python -m lab " + shlex.join(getattr(args, "argv", sys.argv[1:]))
    with output_lock(args.out):
        result = job.run(spec, args.out, command=command, say=lambda line: print(line, file=sys.stderr))
    for line in summary(spec, result, args.out):
        print(line, file=sys.stderr)
    return 0


def track_spec(args) -> TrackSpec:
    """The run's settings from the flags; InputError for a flag the chosen mode does not use
    or a bad value (naming the flag)."""
    rig = RigSpec.parse(args.rig, allow_none=True)
    if not rig.has_rig:  # the spec's rule (NO_RIG_UNUSED), applied to the flags given
        for names, why in NO_RIG_UNUSED:
            refuse_unused(args, [flag_dest(n) for n in names], f"with --rig none ({flag_text(why)})")
    if args.period_s is not None:
        refuse_unused(args, SETTLED_ONLY, "in a streamed run (--period-s streams open loop or feed-forward)")
    else:
        refuse_unused(args, STREAMED_ONLY, "without --period-s (streaming flags need --period-s T)")
        if args.closed_loop is None:
            refuse_unused(args, CLOSED_LOOP_ONLY, "in an open-loop run (they need --closed-loop ilc|feedback)")
    if args.soft_ik:
        refuse_unused(args, SPREAD_ONLY, "with --soft-ik (the FEM has no spread)")
    ik = spec_from_args(IKConfig, args, base=IKConfig.automatic())
    return spec_from_args(
        TrackSpec,
        args,
        model=args.model,
        robot=args.robot,
        seed=args.seed,
        rig=rig,
        mesh=spec_from_args(MeshSpec, args),
        ik=ik,
        correction=spec_from_args(Correction, args),
        stream=None if args.period_s is None else spec_from_args(StreamSpec, args),
    )


def summary(spec: TrackSpec, result, out) -> list[str]:
    """What the run did, in a few lines for the terminal."""
    if not spec.rig.has_rig:
        return result.summary(out)
    if spec.stream is not None:
        k = result.knots
        return [
            f"{result.trajectory} streamed at T = {result.period_s:g} s ({result.mode}, {result.n_periods} periods, "
            f"{result.command_rate_hz:g} commands/s): mean error {100 * result.mean_error_m:.4f} cm, max "
            f"{100 * result.max_error_m:.4f} cm over the last period's {len(result.errors_m)} frames; "
            f"{int(np.sum(~k.reachable))} equilibria out of reach, motors up to {k.max_motor_speed_rad_s:.2f} rad/s "
            f"-> {out}"
        ]
    lines = [
        f"{spec.closed_loop} pass {p['pass']}: mean error {100 * p['mean_error_m']:.4f} cm, max "
        f"{100 * p['max_error_m']:.4f} cm"
        + (f", {p['n_skipped']} corrections skipped (too few valid frames)" if p["n_skipped"] else "")
        for p in result.passes or ()
    ]
    t, sol = result.timings, result.info["solver"]
    uncertain = f", {int(np.sum(result.uncertain))} uncertain" if sol["max_spread_m"] is not None else ""
    lines.append(
        f"{result.trajectory}: {len(result.targets_W)} targets, mean error {100 * result.mean_error_m:.4f} cm, max "
        f"{100 * result.max_error_m:.4f} cm, {int(np.sum(~result.reachable))} unreachable{uncertain}; IK "
        f"({sol['method']}) {1e3 * t['ik_per_target_mean_s']:.2f} ms per target -> {out}"
    )
    if sol["redundant"] or sol["reg_weight"] or sol["posture_weight"] or sol["ik"]["restarts"]:
        lines.append(
            f"IK regularisation: {sol['regularisation']}; {sol['ik']['restarts']} points restarted, "
            f"{sol['ik']['recovered']} of them reached"
        )
    return lines
