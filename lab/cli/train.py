"""``python -m lab train``: train a forward model u -> y (an MLP by default) on a dataset.

The model flags are those of :class:`lab.learn.TrainSpec` (``--model``, ``--hidden``,
``--algorithm``, ``--epochs``, ``--min-grad``, ``--members``, ``--split`` (ratios, random
rows or whole ``group`` sequences), ``--history`` (past commands as inputs), ``--seed``,
``--activation``, ``--jobs``: an ensemble's members, on all cores by default); ``--algorithm
auto``, the default, picks LM or its sub-sampled form by size and the first line says which.
:func:`lab.jobs.train.run` reads the data and fits the model, this command writes it, prints
its errors per set and writes the JSON report.
"""

from __future__ import annotations

import argparse
import json
import shlex

from lab.cli.flags import add_spec_flags, spec_from_args
from lab.cli.paths import check_paths, check_writable
from lab.cli.progress import Progress, add_progress_flag
from lab.jobs import train as job
from lab.learn.train_spec import TrainSpec
from lab.workers import default_jobs


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
    add_spec_flags(t, TrainSpec, default_words={"jobs": "all cores"}, base=_base())
    t.add_argument(
        "--init",
        metavar="MODEL.npz",
        help="mlp: continue training this network (same data and seed: the same split) instead of new weights",
    )
    t.add_argument(
        "--forward",
        help="inverse-mlp: a forward model file (.npz) that judges the commands: tip error |forward(g(y)) - y|",
    )
    t.add_argument("--out", required=True, help="output model file (.npz)")
    t.add_argument("--report", help="also write the train/validation/test errors as JSON here")
    add_progress_flag(t)
    t.set_defaults(func=run)
    return t


def _base() -> TrainSpec:
    """This command's defaults: an ensemble's members on all cores (results do not depend on it)."""
    return TrainSpec(jobs=default_jobs())


def _inputs(args) -> dict:
    extra = args.extra_data
    return {
        "DATA": args.data,
        "DATA sidecar": f"{args.data}.json",
        **{f"--extra-data {p}": p for p in extra},
        **{f"--extra-data {p} sidecar": f"{p}.json" for p in extra},
        **({"--forward": args.forward} if args.forward else {}),
        **({"--init": args.init} if args.init else {}),
    }


def run(args) -> int:
    from lab.files import atomic_write_text

    spec = spec_from_args(TrainSpec, args, base=_base())
    check_paths(_inputs(args), {"--out": args.out, "--report": args.report})
    check_writable(args.out)
    if args.report:
        check_writable(args.report, "--report")
    # epochs come as they are trained, by all of an ensemble's workers together: no division by workers
    with Progress("epoch", enabled=not args.no_progress, at_most=True) as progress:
        result = job.run(
            spec,
            args.data,
            extra_data=args.extra_data,
            init=args.init,
            forward=args.forward,
            command="python -m lab " + shlex.join(args.argv),
            log=progress.write,
            progress=progress.update,
        )
    result.model.save(args.out)
    if result.spec.model == "mlp":
        s = result.stop
        print(
            f"stopped: {result.model.metadata['training']['stop_message']} after {s['epochs']} epochs (best epoch "
            f"{s['best_epoch']}), {result.wall_s:.2f} s"
        )
    else:
        print(f"fitted {result.spec.model} in {result.wall_s:.2f} s")
    size = result.workspace_size_m
    _print_errors(result.errors, size)
    if result.split_info.get("split_warning"):
        print(f"warning: {result.split_info['split_warning']}")
    _print_calibration(result.calibration)
    print(f"workspace size (bounding-box diagonal of the tip data): {1e3 * size:.1f} mm; model -> {args.out}")
    if args.report:
        atomic_write_text(args.report, json.dumps(result.report(args.out), indent=2) + "\n")
    return 0


def _print_calibration(cal: dict | None) -> None:
    for which in ("raw", "scaled"):
        if cal is not None and which in cal:
            c = cal[which]
            print(
                f"test calibration ({which} spread): {100 * c['within_1sigma']:.1f} % within 1 sigma, "
                f"{100 * c['within_2sigma']:.1f} % within 2 sigma (Gaussian 68.3 %, 95.4 %)"
            )


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
