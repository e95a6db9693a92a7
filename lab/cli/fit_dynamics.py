"""``python -m lab fit-dynamics``: learn the foam's relaxation filter of a rig from step
responses and short random motions (:func:`lab.jobs.fit_dynamics.run`).

The rig is driven through the excitation of :mod:`lab.capture.dynamics_probe` while the motion
capture is recorded (:class:`~lab.capture.recorder.StreamRecorder`); ``K`` relaxation modes
(time constants and weights) and every command's equilibrium are fitted to the recording
(:func:`lab.dynamics.relaxation_fit.fit_stream`), and the filter is written as ``DYN.npz``
(:meth:`lab.dynamics.relaxation.Relaxation.save`, kind ``lab.dynamics``) with the robot, the
rig's description, the plan, the command line and the fit's RMS residual in its metadata.
``track --period-s T --dynamic-model DYN.npz`` inverts it into a feed-forward command.
Exit codes: 2 for bad input, 1 when the rig fails.
"""

from __future__ import annotations

import argparse
import shlex
import sys

from lab.capture.dynamics_probe import ProbeSpec
from lab.cli.flags import add_spec_flags, spec_from_args
from lab.cli.paths import check_paths, check_writable, existing
from lab.errors import InputError
from lab.fem.bodies.mesh_spec import MeshSpec
from lab.jobs import fit_dynamics as job


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
        help="twin[:DEFECTS.toml] | twin:random:SEED | twin:foam:SEED | hardware:CONFIG.toml (default twin; "
        "sim has no dynamics to learn)",
    )
    c.add_argument("--robot", default="three-cable", help="shipped robot name or path to a TOML description")
    c.add_argument("--out", required=True, help="output dynamic model (.npz)")
    c.add_argument("--seed", type=int, default=0, help="seed of the random commands (and of an emulated rig's noise)")
    add_spec_flags(c, ProbeSpec)
    add_spec_flags(
        c,
        MeshSpec,
        help={"n_rings": "FEM mesh rings of an emulated twin", "n_axial": "FEM mesh layers of an emulated twin"},
        default_words={"n_rings": "its own", "n_axial": "its own"},
    )
    c.set_defaults(func=run)
    return c


def run(args) -> int:
    """``python -m lab fit-dynamics``; returns the exit code."""
    from lab.description import load_robot
    from lab.rig import RigSpec

    rig_spec = RigSpec.parse(args.rig)
    check_paths({"--robot": existing(args.robot), "--rig": existing(rig_spec.file)}, {"--out": args.out})
    check_writable(args.out)
    if not str(args.out).endswith(".npz"):
        raise InputError(f"--out {args.out}: a dynamic model is written as .npz")
    probe = spec_from_args(ProbeSpec, args)
    rig_spec.require_dynamics()  # sim: the quasi-static FEM has no dynamics
    mesh = spec_from_args(MeshSpec, args)
    if not mesh.is_default and rig_spec.kind != "twin":
        raise InputError("--n-rings/--n-axial set the FEM mesh of an emulated twin only")
    command = "python -m lab " + shlex.join(getattr(args, "argv", sys.argv[1:]))
    say = lambda line: print(line, file=sys.stderr)
    job.run(probe, args.rig, load_robot(args.robot), args.out, seed=args.seed, mesh=mesh, command=command, say=say)
    return 0
