"""``python -m lab splits``: the ten-split accuracy study (Section V-A.3) of a model on a dataset.

Any model of ``--model`` (the flags of :class:`lab.learn.TrainSpec`, here with the paper's
90/0/10 random split and all cores by default; ``--split group`` holds out whole
measurement sequences, ``--history K`` fits on the past commands too); the splits are
those of ``--model mlp`` for the same ``--seed`` (the same test indices), so the rows of
two models pair up split by split (:func:`lab.jobs.splits.run`,
:func:`lab.learn.models.evaluate_model_splits`).
"""

from __future__ import annotations

import argparse
import shlex

from lab.cli.flags import add_spec_flags, refuse_unused, spec_from_args
from lab.cli.paths import check_paths, check_writable
from lab.cli.progress import Progress, add_progress_flag
from lab.jobs import splits as job
from lab.jobs.splits import SplitsSpec
from lab.learn.train_spec import TrainSpec
from lab.workers import default_jobs

HELP = {
    "ratios": "split ratios (as the paper's Section V-A study), after an optional word: random rows (the "
    "default) or group: whole measurement sequences (fewer than 3 are cut into 10 contiguous blocks); a word "
    "alone keeps the ratios",
    "seed": "seed the split seeds are derived from",
    "jobs": "worker processes",
}


def _base() -> TrainSpec:
    """This command's defaults: the paper's 90/0/10 split, all cores."""
    return TrainSpec(ratios=(0.9, 0.0, 0.1), jobs=default_jobs())


def _split_words(args) -> None:
    """A bare ``--split WORD`` keeps this command's ratios (90/0/10), not train's."""
    if args.ratios is not None and len(args.ratios) == 1:
        args.ratios = [*args.ratios, *map(str, _base().ratios)]


def add_parser(subparsers, parents=()) -> argparse.ArgumentParser:
    """Add this command to an ``argparse`` subparsers object; returns its parser."""
    e = subparsers.add_parser(
        "splits", parents=parents, help="accuracy over random splits: train a model on each, report test errors"
    )
    e.add_argument("data", help="dataset CSV (u0..,x,y,z)")
    add_spec_flags(e, TrainSpec, help=HELP, default_words={"jobs": "all cores"}, base=_base())
    add_spec_flags(e, SplitsSpec)
    e.add_argument(
        "--forward",
        help="inverse-mlp: a forward model file (.npz) that judges the commands: tip error |forward(g(y)) - y|",
    )
    e.add_argument("--init", help=argparse.SUPPRESS)  # once shared with train's flags: refused, never used
    e.add_argument("--out", required=True, help="CSV, one row per split (lab.learn.evaluate_model_splits keys)")
    add_progress_flag(e)
    e.set_defaults(func=run)
    return e


def run(args) -> int:
    from lab.learn.studies import write_csv

    _split_words(args)
    spec, splits = spec_from_args(TrainSpec, args, base=_base()), spec_from_args(SplitsSpec, args)
    check_paths(
        {
            "DATA": args.data,
            "DATA sidecar": f"{args.data}.json",
            **({"--forward": args.forward} if args.forward else {}),
            **({"--init": args.init} if args.init else {}),
        },
        {"--out": args.out},
    )
    refuse_unused(args, ["init"], "by splits: every split trains new weights (continue a network with train --init)")
    check_writable(args.out)
    workers = min(spec.jobs, splits.n_splits)
    with Progress("split", enabled=not args.no_progress, parallel=workers) as progress:
        rows, size = job.run(
            spec,
            splits,
            args.data,
            forward=args.forward,
            command="python -m lab " + shlex.join(args.argv),
            log=progress.write,
            progress=progress.update,
        )
    write_csv(args.out, rows)
    _print_summary(rows, size, args.out)
    if rows and rows[0].get("split_method") == "group":
        n_rows = sum(int(rows[0][f"{k}_n"]) for k in ("train", "validation", "test"))
        for note in job.split_warnings(rows, n_rows, spec.ratios):
            print(f"warning: {note}")
    return 0


def _print_summary(rows: list[dict], size: float, out) -> None:
    from lab.learn.studies import summarize

    for s in summarize(rows, "model", "test_mean_distance_m"):
        print(
            f"test mean distance over {s['n']} splits: {1e3 * s['mean']:.4f} mm (std {1e3 * s['std']:.4f}), "
            f"{100 * s['mean'] / size:.3f} % of the {1e3 * size:.1f} mm workspace"
        )
    mse = summarize(rows, "model", "test_mse_m2")[0]
    print(f"test MSE: {mse['mean']:.3e} m^2; fit time {sum(r['wall_s'] for r in rows):.1f} s in all; rows -> {out}")
    for prefix, what in (("test_raw_", " before the spread scale"), ("test_", "")):
        if f"{prefix}within_1sigma" in rows[0]:
            c1, c2 = (summarize(rows, "model", f"{prefix}within_{k}sigma")[0]["mean"] for k in (1, 2))
            print(
                f"test calibration{what}: {100 * c1:.1f} % within 1 sigma, {100 * c2:.1f} % within 2 sigma "
                "(Gaussian 68.3, 95.4)"
            )
    if "test_mean_command_error_rad" in rows[0]:
        c = summarize(rows, "model", "test_mean_command_error_rad")[0]
        print(f"test command error of the direct inverse: {c['mean']:.5f} rad")
