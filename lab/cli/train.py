"""``python -m lab train``: train the forward model u -> y (an MLP) on a dataset."""

from __future__ import annotations

import argparse
import shlex
import sys

import numpy as np

from lab.cli.paths import check_paths, check_writable
from lab.errors import InputError


def add_parser(subparsers, parents=()) -> argparse.ArgumentParser:
    """Add this command to an ``argparse`` subparsers object; returns its parser."""
    t = subparsers.add_parser("train", parents=parents, help="train the forward model u -> y (an MLP) on a dataset")
    t.add_argument("data", help="dataset CSV (u0..,x,y,z), e.g. data/sim_three_cable.csv")
    t.add_argument(
        "--hidden", type=int, nargs="+", default=[20, 20], metavar="WIDTH", help="hidden layer widths (default: 20 20)"
    )
    t.add_argument("--out", required=True, help="output model file (.npz)")
    t.add_argument("--report", help="also write the train/validation/test errors as JSON here")
    t.add_argument(
        "--split",
        type=float,
        nargs=3,
        default=[0.8, 0.1, 0.1],
        metavar=("TRAIN", "VAL", "TEST"),
        help="random split ratios like MATLAB dividerand (default: 0.8 0.1 0.1)",
    )
    t.add_argument("--seed", type=int, default=0, help="seed of the split and the initial weights")
    t.add_argument("--activation", choices=["tanh", "logistic"], default="tanh", help="hidden activation")
    t.add_argument(
        "--algorithm",
        choices=["lm", "adam", "lbfgs"],
        default="lm",
        help="Levenberg-Marquardt (MATLAB trainlm, default), Adam or L-BFGS",
    )
    t.add_argument("--epochs", type=int, help="maximum epochs (default 1000)")
    t.add_argument("--min-grad", type=float, help="LM: gradient stop (default 1e-6; 0 disables)")
    t.set_defaults(func=run)

    return t


def run(args) -> int:
    import hashlib
    import json
    from pathlib import Path

    from lab.data.dataset import read_dataset
    from lab.files import atomic_write_text, code_version
    from lab.learn.lm import LMOptions
    from lab.learn.metrics import workspace_size_m
    from lab.learn.train import train

    check_paths({"DATA": args.data, "DATA sidecar": f"{args.data}.json"}, {"--out": args.out, "--report": args.report})
    check_writable(args.out)
    if args.report:
        check_writable(args.report, "--report")
    u, y, meta = read_dataset(args.data)
    if any(h < 1 for h in args.hidden):
        raise InputError(f"--hidden widths must be positive, got {args.hidden}")
    if args.epochs is not None and args.epochs < 1:
        raise InputError(f"--epochs must be positive, got {args.epochs}")
    options = LMOptions(min_grad=args.min_grad) if args.algorithm == "lm" and args.min_grad is not None else None
    print(
        f"{args.data}: {len(u)} samples, {u.shape[1]} inputs -> {y.shape[1]} outputs; training "
        f"{'-'.join(map(str, [u.shape[1], *args.hidden, y.shape[1]]))} ({args.activation}) with "
        f"{args.algorithm}, split {args.split}, seed {args.seed}",
        file=sys.stderr,
    )
    res = train(
        u,
        y,
        args.hidden,
        activation=args.activation,
        algorithm=args.algorithm,
        ratios=args.split,
        seed=args.seed,
        epochs=args.epochs,
        options=options,
    )
    file_sha = hashlib.sha256(Path(args.data).read_bytes()).hexdigest()
    training = res.model.metadata["training"]
    training["data"] = {"path": str(args.data), "file_sha256": file_sha, "robot": (meta.get("robot") or {}).get("name")}
    training["command"] = "python -m lab " + shlex.join(args.argv)
    res.model.save(args.out)
    size = workspace_size_m(y) or float("nan")
    print(
        f"stopped: {training['stop_message']} after {res.log.epochs} epochs (best epoch "
        f"{res.log.best_epoch}), {res.log.wall_s:.2f} s"
    )
    print(f"{'set':<11}{'n':>5}{'MSE [m^2]':>13}{'mean dist [mm]':>16}{'% of workspace':>16}")
    for name, err in res.errors.items():
        if err["n"]:
            print(
                f"{name:<11}{err['n']:>5}{err['mse_m2']:>13.3e}{1e3 * err['mean_distance_m']:>16.4f}"
                f"{100 * err['mean_distance_m'] / size:>16.4f}"
            )
        else:
            print(f"{name:<11}{0:>5}{'-':>13}{'-':>16}{'-':>16}")
    print(f"workspace size (bounding-box diagonal of the tip data): {1e3 * size:.1f} mm; model -> {args.out}")
    if args.report:
        report = {
            "kind": "lab.train_report",
            "format_version": 1,
            **res.errors,
            "workspace_size_m": size if np.isfinite(size) else None,
            "model": str(args.out),
            "data": str(args.data),
            "data_file_sha256": file_sha,
            "data_sha256": training["data_sha256"],
            "layer_sizes": list(res.model.layer_sizes),
            "activation": args.activation,
            "algorithm": args.algorithm,
            "seed": args.seed,
            "split": list(args.split),
            "stop_reason": res.log.stop_reason,
            "epochs": res.log.epochs,
            "best_epoch": res.log.best_epoch,
            "wall_s": res.log.wall_s,
            "code_version": code_version(),
        }
        atomic_write_text(args.report, json.dumps(report, indent=2) + "\n")
    return 0
