"""``python -m lab import-data``: external measurements (CSV files) -> a lab dataset.

    python -m lab import-data runs.csv --u m1,m2,m3 --y tip_x,tip_y,tip_z --y-unit mm --group run --out mine.csv
    python -m lab import-data in1.csv in2.csv --observations obs1.csv obs2.csv --id ID \\
        --u u1,u2,u3,u4,u5,u6 --y x3,y3,z3 --u-unit effort --out trunk.csv
    python -m lab import-data tendons.csv --robot tentacle.toml --u T1,T2 --u-unit N \\
        --y x,y,z,ring_x,ring_y,ring_z --out tentacle.csv

Each FILE holds the ``--u`` and ``--y`` columns (the tip's x,y,z, then each marker's); with
``--observations`` FILE i holds the inputs and OBS i the positions, paired row by row or on
``--id COL``. Every file or pair starts a measurement sequence (``--group COL``: also where COL changes).
Values implausible for their unit (a tip 100 m away: millimetres read as metres) are refused,
naming the unit they look like; the summary names the units read (--u-unit's default, rad,
included). The flags are
:class:`lab.data.import_spec.ImportSpec`; :func:`lab.jobs.import_data.run` reads,
joins, converts to metres and writes the dataset and its sidecar (provenance, licence,
dropped rows, sequence starts). The rules: docs/import-data.md.
"""

from __future__ import annotations

import argparse
import shlex
import sys

from lab.cli.flags import add_spec_flags, refuse_unused, spec_from_args
from lab.cli.paths import check_paths, check_writable, dataset_outputs, existing, output_lock
from lab.data.import_spec import ImportSpec
from lab.jobs import import_data as job


def add_parser(subparsers, parents=()) -> argparse.ArgumentParser:
    """Add the ``import-data`` command to an ``argparse`` subparsers object."""
    p = subparsers.add_parser(
        "import-data",
        parents=parents,
        help="import external measurements (CSV files of inputs and positions) as a lab dataset",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("files", nargs="+", metavar="FILE", help="CSV files with the --u (and, alone, the --y) columns")
    p.add_argument(
        "--observations",
        nargs="+",
        metavar="OBS",
        help="CSV files with the --y columns: OBS i pairs with FILE i, row by row or on --id",
    )
    add_spec_flags(p, ImportSpec)
    p.add_argument("--out", required=True, help="output dataset CSV (u0..,x,y,z; metres) and its .json sidecar")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    if not args.observations:
        refuse_unused(args, ["id"], "without --observations: it pairs the rows of a FILE and an OBS file")
    spec = spec_from_args(ImportSpec, args)
    observations = args.observations or []
    inputs = {f"FILE {p}": p for p in args.files} | {f"--observations {p}": p for p in observations}
    if spec.robot is not None:
        inputs["--robot"] = existing(spec.robot)
    check_paths(inputs, {**dataset_outputs("--out", args.out), "--out lock": f"{args.out}.lock"})
    check_writable(args.out)
    with output_lock(args.out):
        result = job.run(
            spec, args.files, args.out, observations=observations, command="python -m lab " + shlex.join(args.argv)
        )
    dropped = ", ".join(f"{n} {why}" for why, n in result.dropped.items() if n) or "none"
    for note in result.notes:
        print(f"note: {note}", file=sys.stderr)
    print(
        f"imported {result.n_rows} rows in {result.n_sequences} sequence(s) from {result.n_groups} "
        f"{'pair' if observations else 'file'}(s) (rows dropped: {dropped}) -> {args.out}"
    )
    print(f"units: inputs {_unit_words(spec, args)}; positions {spec.y_unit}, written in m")
    return 0


def _unit_words(spec: ImportSpec, args) -> str:
    """The inputs' unit as read, saying so when it is ``--u-unit``'s default (rad): data in
    another unit would pass unnoticed while their values look like angles."""
    given = any(a.startswith("--u-u") for a in args.argv)  # argparse takes any unambiguous prefix
    if given:
        return spec.u_unit
    return f"{spec.u_unit} (the default of --u-unit; give --u-unit if they are tensions, pressures or another unit)"
