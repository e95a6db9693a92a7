"""``python -m lab splits``: the ten-split accuracy study (Section V-A.3) of a network on a dataset."""

from __future__ import annotations

import argparse
import shlex
import sys

from lab.cli.paths import check_paths, check_writable
from lab.errors import InputError
from lab.workers import default_jobs


def add_parser(subparsers, parents=()) -> argparse.ArgumentParser:
    """Add this command to an ``argparse`` subparsers object; returns its parser."""
    e = subparsers.add_parser(
        "splits", parents=parents, help="accuracy over random splits: train a network on each, report test errors"
    )
    e.add_argument("data", help="dataset CSV (u0..,x,y,z)")
    e.add_argument(
        "--hidden", type=int, nargs="+", default=[20, 20], metavar="WIDTH", help="hidden layer widths (default: 20 20)"
    )
    e.add_argument("--n-splits", type=int, default=10, help="number of random splits (default 10)")
    e.add_argument(
        "--split",
        type=float,
        nargs=3,
        default=[0.9, 0.0, 0.1],
        metavar=("TRAIN", "VAL", "TEST"),
        help="split ratios (default 0.9 0 0.1, as the paper's Section V-A study)",
    )
    e.add_argument("--seed", type=int, default=0, help="seed the split seeds are derived from")
    e.add_argument("--min-grad", type=float, help="LM gradient stop (default 1e-6, the paper's)")
    e.add_argument("--jobs", type=int, default=default_jobs(), help="worker processes (default: all cores)")
    e.add_argument("--out", required=True, help="CSV, one row per split (lab.learn.evaluate_splits keys)")
    e.set_defaults(func=run)

    return e


def run(args) -> int:
    from lab.data.dataset import read_dataset
    from lab.learn.lm import LMOptions
    from lab.learn.metrics import workspace_size_m
    from lab.learn.studies import evaluate_splits, summarize, write_csv

    check_paths({"DATA": args.data, "DATA sidecar": f"{args.data}.json"}, {"--out": args.out})
    check_writable(args.out)
    u, y, _ = read_dataset(args.data)
    if any(h < 1 for h in args.hidden) or args.n_splits < 1 or args.jobs < 1:
        raise InputError("--hidden widths, --n-splits and --jobs must be positive")
    print(
        f"{args.data}: {len(u)} samples; {args.n_splits} random splits {args.split} of a "
        f"{'-'.join(map(str, [u.shape[1], *args.hidden, y.shape[1]]))} network, seed {args.seed}, "
        f"{args.jobs} worker(s)",
        file=sys.stderr,
    )
    options = LMOptions(min_grad=args.min_grad) if args.min_grad is not None else None
    rows = evaluate_splits(
        u,
        y,
        args.hidden,
        n_splits=args.n_splits,
        ratios=tuple(args.split),
        seed=args.seed,
        n_jobs=args.jobs,
        options=options,
    )
    for r in rows:
        r["command"] = "python -m lab " + shlex.join(args.argv)
    write_csv(args.out, rows)
    size = workspace_size_m(y)
    for s in summarize(rows, "hidden", "test_mean_distance_m"):
        print(
            f"test mean distance over {s['n']} splits: {1e3 * s['mean']:.4f} mm (std {1e3 * s['std']:.4f}), "
            f"{100 * s['mean'] / size:.3f} % of the {1e3 * size:.1f} mm workspace"
        )
    mse = summarize(rows, "hidden", "test_mse_m2")[0]
    print(f"test MSE: {mse['mean']:.3e} m^2; rows -> {args.out}")
    return 0
