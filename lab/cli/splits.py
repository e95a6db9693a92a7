"""``python -m lab splits``: the ten-split accuracy study (Section V-A.3) of a model on a dataset.

Any model of ``--model`` (:data:`lab.learn.models.MODEL_CHOICES`); the splits are those
of ``--model mlp`` for the same ``--seed`` (the same test indices), so the rows of two
models pair up split by split (:func:`lab.learn.models.evaluate_model_splits`).
"""

from __future__ import annotations

import argparse
import shlex
import sys

from lab.cli.paths import check_paths, check_writable
from lab.cli.train import add_model_arguments, check_model_arguments, fit_arguments
from lab.errors import InputError
from lab.workers import default_jobs


def add_parser(subparsers, parents=()) -> argparse.ArgumentParser:
    """Add this command to an ``argparse`` subparsers object; returns its parser."""
    e = subparsers.add_parser(
        "splits", parents=parents, help="accuracy over random splits: train a model on each, report test errors"
    )
    e.add_argument("data", help="dataset CSV (u0..,x,y,z)")
    add_model_arguments(e)
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
    e.add_argument("--activation", choices=["tanh", "logistic"], default="tanh", help="hidden activation")
    e.add_argument("--jobs", type=int, default=default_jobs(), help="worker processes (default: all cores)")
    e.add_argument("--out", required=True, help="CSV, one row per split (lab.learn.evaluate_model_splits keys)")
    e.set_defaults(func=run)

    return e


def run(args) -> int:
    from lab.data.dataset import read_dataset
    from lab.learn.metrics import workspace_size_m
    from lab.learn.models import evaluate_model_splits, load_model
    from lab.learn.studies import summarize, write_csv

    check_paths(
        {
            "DATA": args.data,
            "DATA sidecar": f"{args.data}.json",
            **({"--forward": args.forward} if args.forward else {}),
        },
        {"--out": args.out},
    )
    check_writable(args.out)
    u, y, _ = read_dataset(args.data)
    if args.n_splits < 1 or args.jobs < 1:
        raise InputError("--n-splits and --jobs must be positive")
    check_model_arguments(args)
    forward = load_model(args.forward) if args.forward else None
    net = "-".join(map(str, [u.shape[1], *args.hidden, y.shape[1]]))
    what = {
        "mlp": f"{net} network ({args.algorithm})",
        "ensemble": f"{args.members} x {net} ensemble ({args.algorithm})",
    }
    print(
        f"{args.data}: {len(u)} samples; {args.n_splits} random splits {args.split} of a "
        f"{what.get(args.model, args.model)}, seed {args.seed}, {args.jobs} worker(s)",
        file=sys.stderr,
    )
    rows = evaluate_model_splits(
        u,
        y,
        args.model,
        n_splits=args.n_splits,
        ratios=tuple(args.split),
        seed=args.seed,
        n_jobs=args.jobs,
        forward=forward,
        **fit_arguments(args),
    )
    for r in rows:
        r["command"] = "python -m lab " + shlex.join(args.argv)
    write_csv(args.out, rows)
    size = workspace_size_m(y)
    for s in summarize(rows, "model", "test_mean_distance_m"):
        print(
            f"test mean distance over {s['n']} splits: {1e3 * s['mean']:.4f} mm (std {1e3 * s['std']:.4f}), "
            f"{100 * s['mean'] / size:.3f} % of the {1e3 * size:.1f} mm workspace"
        )
    mse = summarize(rows, "model", "test_mse_m2")[0]
    print(
        f"test MSE: {mse['mean']:.3e} m^2; fit time {sum(r['wall_s'] for r in rows):.1f} s in all; rows -> {args.out}"
    )
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
    return 0
