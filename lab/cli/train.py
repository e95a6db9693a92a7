"""``python -m lab train``: train a forward model u -> y (an MLP by default) on a dataset.

``--model`` picks any model of :data:`lab.learn.models.MODEL_CHOICES`. The network
(``mlp``) is split, initialised and trained by :func:`lab.learn.train.train` as before;
every other model is fitted on the training part of the same ``dividerand`` split (same
seed, same indices) and its errors are reported on all three parts. An ensemble's spread
scale is fitted on the validation part, and its calibration on the test part is reported
before and after (:func:`lab.learn.ensemble.calibration`).
"""

from __future__ import annotations

import argparse
import shlex
import sys

import numpy as np

from lab.cli.paths import check_paths, check_writable
from lab.errors import InputError

MODEL_CHOICES = ("mlp", "ensemble", "gpr", "knn", "sklearn-mlp", "inverse-mlp")  # lab.learn.models.MODEL_CHOICES


def add_parser(subparsers, parents=()) -> argparse.ArgumentParser:
    """Add this command to an ``argparse`` subparsers object; returns its parser."""
    t = subparsers.add_parser("train", parents=parents, help="train the forward model u -> y (an MLP) on a dataset")
    t.add_argument("data", help="dataset CSV (u0..,x,y,z), e.g. data/sim_three_cable.csv")
    t.add_argument(
        "--extra-data",
        nargs="+",
        default=[],
        metavar="CSV",
        help="more datasets of the same robot, appended to DATA before the split (e.g. Sobol samples between "
        "a grid's lattice points)",
    )
    add_model_arguments(t)
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
    t.add_argument("--jobs", type=int, default=1, help="ensemble: worker processes training the members (default 1)")
    t.set_defaults(func=run)

    return t


def add_model_arguments(p: argparse.ArgumentParser) -> None:
    """The model flags ``train`` and ``splits`` share."""
    p.add_argument(
        "--hidden", type=int, nargs="+", default=[20, 20], metavar="WIDTH", help="hidden layer widths (default: 20 20)"
    )
    p.add_argument(
        "--model",
        choices=MODEL_CHOICES,
        default="mlp",
        help="lab's network (default), a deep ensemble of them, or a scikit-learn peer "
        "(Gaussian process, k-nearest neighbours, MLPRegressor), or the direct inverse u = g(y)",
    )
    p.add_argument(
        "--algorithm",
        choices=["lm", "adam", "lbfgs", "br"],
        default="lm",
        help="network training: Levenberg-Marquardt (MATLAB trainlm, default), Adam, L-BFGS, or "
        "Bayesian regularisation (MATLAB trainbr)",
    )
    p.add_argument("--epochs", type=int, help="maximum epochs (default 1000)")
    p.add_argument("--min-grad", type=float, help="LM/BR: gradient stop (default 1e-6 for lm, 1e-7 for br; 0 disables)")
    p.add_argument(
        "--init",
        metavar="MODEL.npz",
        help="mlp: continue training this network (same data and seed: the same split) instead of new weights",
    )
    p.add_argument("--members", type=int, default=5, help="ensemble: number of networks K >= 2 (default 5)")
    p.add_argument(
        "--forward",
        help="inverse-mlp: a forward model file (.npz) that judges the commands: tip error |forward(g(y)) - y|",
    )


def check_model_arguments(args) -> None:
    """InputError (exit 2) for values argparse cannot check."""
    if any(h < 1 for h in args.hidden):
        raise InputError(f"--hidden widths must be positive, got {args.hidden}")
    if args.epochs is not None and args.epochs < 1:
        raise InputError(f"--epochs must be positive, got {args.epochs}")
    if args.model == "ensemble" and args.members < 2:
        raise InputError(f"--members must be at least 2, got {args.members}")
    if args.forward and args.model != "inverse-mlp":
        raise InputError("--forward only applies to --model inverse-mlp")


def fit_arguments(args) -> dict:
    """The keyword arguments of :func:`lab.learn.models.fit_model` the flags give."""
    from lab.learn.models import net_options

    return {
        "hidden": tuple(args.hidden),
        "algorithm": args.algorithm,
        "epochs": args.epochs,
        "options": net_options(args.algorithm, args.min_grad),
        "activation": args.activation,
        "members": args.members,
    }


def _finite_or_none(d: dict) -> dict:
    return {k: (None if isinstance(v, float) and not np.isfinite(v) else v) for k, v in d.items()}


def _fit_other(args, u, y, forward):
    """A model other than the plain network on the training part of train's own split;
    returns (model, errors per set, calibration or None, split, wall_s)."""
    import time

    from lab.learn.ensemble import calibration
    from lab.learn.models import fit_model, held_out_errors, outer_split
    from lab.learn.split import check_enough_data

    check_enough_data(u, args.split)
    split = outer_split(len(u), args.split, args.seed)
    t0 = time.perf_counter()
    model = fit_model(
        args.model, u[split.train], y[split.train], seed=args.seed, n_jobs=args.jobs, **fit_arguments(args)
    )
    wall_s = time.perf_counter() - t0
    sets = {"train": split.train, "validation": split.validation, "test": split.test}
    cal = None
    if args.model in ("ensemble", "gpr") and len(split.test):
        u_t, y_t = u[split.test], y[split.test]
        if args.model == "ensemble":
            cal = {"raw": calibration(y_t, *model.predict_with_std(u_t, scaled=False))}
            if len(split.validation):
                model.fit_spread_scale(u[split.validation], y[split.validation])
                cal["scaled"] = calibration(y_t, *model.predict_with_std(u_t))
                cal["spread_scale"] = model.spread_scale
        else:
            cal = {"raw": calibration(y_t, *model.predict_with_std(u_t))}
    errors = {name: _finite_or_none(held_out_errors(model, u[idx], y[idx], forward)) for name, idx in sets.items()}
    training = model.metadata.setdefault("training", {})
    training.update(
        {
            "model": args.model,
            "seed": args.seed,
            "split": {
                "method": "dividerand",
                "ratios": list(map(float, args.split)),
                **split.sizes(),
                "indices": {k: v.tolist() for k, v in sets.items()},
            },
            "errors": errors,
            "wall_s": wall_s,
        }
    )
    if cal is not None:
        training["calibration_test"] = cal
    return model, errors, cal, wall_s


def run(args) -> int:
    import hashlib
    import json
    from pathlib import Path

    from lab.data.dataset import read_dataset
    from lab.files import atomic_write_text, code_version
    from lab.learn.metrics import workspace_size_m
    from lab.learn.models import load_model
    from lab.learn.train import data_sha256, train

    check_paths(
        {
            "DATA": args.data,
            "DATA sidecar": f"{args.data}.json",
            **{f"--extra-data {p}": p for p in args.extra_data},
            **{f"--extra-data {p} sidecar": f"{p}.json" for p in args.extra_data},
            **({"--forward": args.forward} if args.forward else {}),
            **({"--init": args.init} if args.init else {}),
        },
        {"--out": args.out, "--report": args.report},
    )
    check_writable(args.out)
    if args.report:
        check_writable(args.report, "--report")
    u, y, meta = read_dataset(args.data)
    extra = []
    for path in args.extra_data:
        u_x, y_x, meta_x = read_dataset(path)
        robot_x, robot = ((m.get("robot") or {}).get("name") for m in (meta_x, meta))
        if u_x.shape[1] != u.shape[1] or robot_x != robot:
            raise InputError(
                f"--extra-data {path}: robot {robot_x!r} with {u_x.shape[1]} motors, but {args.data} is robot "
                f"{robot!r} with {u.shape[1]}"
            )
        u, y = np.vstack([u, u_x]), np.vstack([y, y_x])
        extra.append({"path": str(path), "file_sha256": hashlib.sha256(Path(path).read_bytes()).hexdigest()})
    check_model_arguments(args)
    if args.jobs < 1:
        raise InputError(f"--jobs must be positive, got {args.jobs}")
    forward = load_model(args.forward) if args.forward else None
    init = None
    if args.init:
        from lab.learn.mlp import MLP

        init = load_model(args.init)
        if args.model != "mlp" or not isinstance(init, MLP):
            raise InputError(f"--init {args.init}: continues an mlp (lab.mlp file) with --model mlp only")
        args.hidden = list(init.hidden)
    what = "-".join(map(str, [u.shape[1], *args.hidden, y.shape[1]]))
    what = {"mlp": what, "ensemble": f"{args.members} x {what}", "inverse-mlp": f"inverse {what}"}.get(args.model, "")
    print(
        f"{' + '.join([args.data, *args.extra_data])}: {len(u)} samples, {u.shape[1]} inputs -> {y.shape[1]} "
        f"outputs; training {args.model}"
        f"{f' {what} ({args.activation}) with {args.algorithm}' if what else ''}, split {args.split}, seed {args.seed}",
        file=sys.stderr,
    )
    cal = None
    if args.model == "mlp":
        res = train(
            u,
            y,
            args.hidden,
            activation=args.activation,
            algorithm=args.algorithm,
            ratios=args.split,
            seed=args.seed,
            epochs=args.epochs,
            options=fit_arguments(args)["options"],
            init=init,
        )
        model, errors, wall_s = res.model, res.errors, res.log.wall_s
        stop = {"stop_reason": res.log.stop_reason, "epochs": res.log.epochs, "best_epoch": res.log.best_epoch}
    else:
        model, errors, cal, wall_s = _fit_other(args, u, y, forward)
        stop = {"stop_reason": None, "epochs": None, "best_epoch": None}
    file_sha = hashlib.sha256(Path(args.data).read_bytes()).hexdigest()
    training = model.metadata["training"]
    training.setdefault("data_sha256", data_sha256(u, y))
    training["data"] = {"path": str(args.data), "file_sha256": file_sha, "robot": (meta.get("robot") or {}).get("name")}
    if extra:
        training["data"]["extra"] = extra
    training["command"] = "python -m lab " + shlex.join(args.argv)
    model.save(args.out)
    size = workspace_size_m(y) or float("nan")
    if args.model == "mlp":
        print(
            f"stopped: {training['stop_message']} after {res.log.epochs} epochs (best epoch "
            f"{res.log.best_epoch}), {res.log.wall_s:.2f} s"
        )
    else:
        print(f"fitted {args.model} in {wall_s:.2f} s")
    _print_errors(errors, size)
    if cal is not None:
        for which in ("raw", "scaled"):
            if which in cal:
                c = cal[which]
                print(
                    f"test calibration ({which} spread): {100 * c['within_1sigma']:.1f} % within 1 sigma, "
                    f"{100 * c['within_2sigma']:.1f} % within 2 sigma (Gaussian 68.3 %, 95.4 %)"
                )
    print(f"workspace size (bounding-box diagonal of the tip data): {1e3 * size:.1f} mm; model -> {args.out}")
    if args.report:
        report = {
            "kind": "lab.train_report",
            "format_version": 1,
            **errors,
            "workspace_size_m": size if np.isfinite(size) else None,
            "model": str(args.out),
            "model_type": args.model,
            "data": str(args.data),
            "data_file_sha256": file_sha,
            "data_sha256": training["data_sha256"],
            "layer_sizes": list(net.layer_sizes)
            if hasattr(net := getattr(model, "net", model), "layer_sizes")
            else None,
            "activation": args.activation,
            "algorithm": args.algorithm,
            "seed": args.seed,
            "split": list(args.split),
            **stop,
            "wall_s": wall_s,
            "code_version": code_version(),
        }
        if args.algorithm == "br" and "bayesian_regularisation" in training:
            report["bayesian_regularisation"] = training["bayesian_regularisation"]
        if cal is not None:
            report["calibration_test"] = cal
        atomic_write_text(args.report, json.dumps(report, indent=2) + "\n")
    return 0


def _print_errors(errors: dict, size: float) -> None:
    command = any("mean_command_error_rad" in e for e in errors.values())
    print(
        f"{'set':<11}{'n':>5}{'MSE [m^2]':>13}{'mean dist [mm]':>16}{'% of workspace':>16}"
        + (f"{'command err [rad]':>19}" if command else "")
    )
    for name, err in errors.items():
        if err["n"]:
            mse, dist = err["mse_m2"], err["mean_distance_m"]
            line = (
                f"{name:<11}{err['n']:>5}"
                + (f"{mse:>13.3e}{1e3 * dist:>16.4f}{100 * dist / size:>16.4f}" if dist is not None else f"{'-':>45}")
                + (f"{err['mean_command_error_rad']:>19.5f}" if command else "")
            )
            print(line)
        else:
            print(f"{name:<11}{0:>5}{'-':>13}{'-':>16}{'-':>16}")
