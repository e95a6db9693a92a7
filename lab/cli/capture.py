"""``python -m lab capture``: the paper's 7x7x7 grid captured on a rig (Section III).

    python -m lab capture --rig twin --robot three-cable --grid 7 --out data/real_three_cable.csv
    python -m lab capture --rig twin:random:3 --design maximin --n 30 --seed 0 --out real30.csv
    python -m lab capture --rig twin --active 200 --batch 20 --out real_active.csv

Captures the safe commands of the grid (308 of 343 for 7 levels) or N commands of a
space-filling design (--sobol N, --lhs N, --design D --n N) with the protocol of
lab.capture.session into an append-only journal (default: OUT with .journal.csv), then writes
the dataset OUT (+ OUT.json) in grid (or design) order. With --active N --batch B each batch
is picked where an ensemble fitted to the samples so far disagrees most (rows in capture
order; --order does not apply). Killed or failed, it keeps every sample so far and the same
command continues where it stopped (an active run first finishes its batch); the rig is
closed (torque off). A robot with [[markers]] is captured at every marker (columns NAME_x,
NAME_y, NAME_z after the tip's; the waiting protocol only); a tension-controlled tendon's
input is in N. Flags: lab.rig.CaptureSpec; the run: lab.jobs.capture.run.
"""

from __future__ import annotations

import argparse
import sys

from lab.capture.spec import CaptureSpec, ProtocolSpec
from lab.cli.flags import add_spec_flags, spec_from_args
from lab.cli.paths import check_paths, check_writable, dataset_outputs, existing, ignore_file_size_signal
from lab.cli.sampling import add_design_flags, design_from_args
from lab.cli.signals import exit_code
from lab.errors import LabError
from lab.jobs import capture as job
from lab.rig.spec import RigSpec


def add_parser(subparsers, parents=()) -> argparse.ArgumentParser:
    """Add the ``capture`` command to an ``argparse`` subparsers object."""
    p = subparsers.add_parser(
        "capture",
        parents=parents,
        help="capture (u, y) samples of a grid on a rig with the paper's protocol",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--rig",
        default="twin",
        help="sim | twin[:DEFECTS.toml] | twin:random:SEED | twin:foam:SEED (an emulated as-built robot of a family) "
        "| hardware:RIG.toml (default: twin)",
    )
    add_spec_flags(p, CaptureSpec, only=("robot",))
    add_design_flags(p)
    add_spec_flags(p, CaptureSpec, only=("out", "journal"))
    p.add_argument(
        "--seed",
        type=int,
        default=0,
        help="seed of the design (or of --active's picks and ensembles), the shuffled order "
        "and the emulated rig's noise",
    )
    add_spec_flags(p, CaptureSpec, only=("order",))
    add_spec_flags(p, ProtocolSpec)
    add_spec_flags(p, CaptureSpec, only=("no_progress",))
    p.set_defaults(func=run)
    return p


def capture_spec(args) -> CaptureSpec:
    """The :class:`CaptureSpec` of the parsed flags; a bad value raises InputError naming its flag."""
    design, protocol = design_from_args(args), spec_from_args(ProtocolSpec, args)
    return spec_from_args(CaptureSpec, args, rig=RigSpec.parse(args.rig), design=design, protocol=protocol)


def run(args) -> int:
    from lab.data.dataset import write_dataset

    spec = capture_spec(args)
    journal = spec.journal_path
    inputs = {"--robot": existing(spec.robot), "--rig": existing(spec.rig.file)}
    outputs = {**dataset_outputs("--out", spec.out), "--journal": journal}
    check_paths({**inputs, "--dynamic-model": spec.protocol.dynamic_model}, outputs)
    check_writable(spec.out)
    check_writable(journal, "--journal")
    ignore_file_size_signal()
    try:
        data = job.run(spec)
    except KeyboardInterrupt as err:  # Ctrl-C, SIGTERM, SIGHUP: the rig is closed (torque off)
        why = f" by {err.args[0]}" if err.args else ""
        print(
            f"interrupted{why}; the rig was closed and every sample captured so far is in {journal}: "
            "run the same command again to continue",
            file=sys.stderr,
        )
        return exit_code(err)
    except (LabError, OSError):  # the message itself is printed by lab.cli.main; the exit code follows the error
        if journal.exists():
            print(
                f"(the rig was closed; samples captured so far are in {journal}; "
                "the same command continues from there)",
                file=sys.stderr,
            )
        raise
    write_dataset(spec.out, data.u_motor, data.outputs, data.meta, **data.write_args())
    print(data.summary, file=sys.stderr)
    return 0
