"""``python -m lab defects``: write the defects file of an emulated as-built robot of the family.

    python -m lab defects --random 3 --robot three-cable --out robot3.toml
    python -m lab capture --rig twin:robot3.toml ...   # the same robot as --rig twin:random:3
    python -m lab defects --foam 3 --out foam3.toml      # the same robot as --rig twin:foam:3
    python -m lab defects --pneumatic 3 --robot pneumatic-arm --out p3.toml  # twin:pneumatic:3

Draws member ``SEED`` of the family of as-built robots (``lab.asbuilt.family``: softness,
stiffness gradient, eyelet shifts, slack, play, lag, motors, motion capture, from ranges
justified there) for the robot description ``--robot`` (any number of cables), and writes
it atomically as a commented defects file in the format of ``lab/rig/defects/``. ``--foam
SEED`` draws member SEED of the foam family instead (``lab.asbuilt.foam``): the same
in-class defects as ``--random SEED``, plus the hyperfoam law, cable stiffness, creep, a
tilted base, the mocap's frame error and a finer emulator mesh. The same seed always gives
the same file; edit it freely and pass it as ``--rig twin:FILE``. ``--pneumatic SEED``
draws a cast-silicone arm driven by pressure chambers (``lab.asbuilt.pneumatic``: cavity
errors, per-chamber stiffness, curing gradient, a tilted base, each chamber's pressure
regulator) for a robot with chambers (``--robot pneumatic-arm``); ``--random``/``--foam``
refuse such a robot. Results on it are an "emulated as-built robot" ("(foam family)",
"(pneumatic family)"), not the real arm.
"""

from __future__ import annotations

import argparse
import shlex
import sys

from lab.asbuilt.member_spec import FamilyMemberSpec
from lab.cli.flags import add_spec_flags, spec_from_args
from lab.cli.paths import check_paths, check_writable, existing
from lab.fem.bodies.mesh_spec import MeshSpec
from lab.jobs import defects as job

MESH_HELP = {
    "n_rings": "FEM mesh rings of the emulator, written to [emulator]",
    "n_axial": "FEM mesh layers of the emulator, written to [emulator]",
}


def add_parser(subparsers, parents=()) -> argparse.ArgumentParser:
    """Add the ``defects`` command to an ``argparse`` subparsers object."""
    p = subparsers.add_parser(
        "defects",
        parents=parents,
        help="write the defects file of an emulated as-built robot (a member of the random, foam or pneumatic family)",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_spec_flags(p, FamilyMemberSpec)
    p.add_argument(
        "--robot",
        default=None,
        help="shipped robot name or path to a TOML description (default three-cable; pneumatic-arm with --pneumatic)",
    )
    add_spec_flags(p, MeshSpec, help=MESH_HELP, default_words={"n_rings": "robot's"})
    p.add_argument("--out", required=True, help="output defects file (TOML)")
    p.set_defaults(func=run)
    return p


def command_line(spec: FamilyMemberSpec, robot: str) -> str:
    """The command that makes the same file (recorded in its header; without ``--out``, so
    that the file depends only on the robot, the seed and the mesh)."""
    words = ["python", "-m", "lab", "defects", f"--{spec.family}", str(spec.member_seed), "--robot", str(robot)]
    for flag, value in (("--n-rings", spec.mesh.n_rings), ("--n-axial", spec.mesh.n_axial)):
        if value is not None:
            words += [flag, str(value)]
    return shlex.join(words) + " --out D.toml"


def run(args) -> int:
    from lab.description import load_robot

    spec = spec_from_args(FamilyMemberSpec, args, mesh=spec_from_args(MeshSpec, args))
    if args.robot is None:
        args.robot = "pneumatic-arm" if spec.family == "pneumatic" else "three-cable"
    check_paths({"--robot": existing(args.robot)}, {"--out": args.out})
    check_writable(args.out)
    robot = load_robot(args.robot)
    defects = job.run(spec, robot, args.out, command=command_line(spec, args.robot))
    family = {"foam": "the foam family", "pneumatic": "the pneumatic family"}.get(spec.family, "the family")
    if spec.family == "pneumatic":
        taus = [c.regulator_tau_s for c in defects.chambers]
        what = f"regulator lag {1e3 * min(taus):.0f}-{1e3 * max(taus):.0f} ms, tilt {defects.tilt_deg:g} deg"
    else:
        what = f"slack up to {1e3 * defects.slack_m.max():.1f} mm"
        if spec.family == "foam":
            what += f", hyperfoam alpha {defects.hyperfoam_alpha:g}, tilt {defects.tilt_deg:g} deg"
    print(
        f"wrote {args.out}: {robot.name} as built, member {spec.member_seed} of {family} (softness "
        f"{defects.softness:g}, gradient {defects.gradient:g}, {what}); use it as --rig twin:{args.out}",
        file=sys.stderr,
    )
    return 0
