"""``python -m lab capture``: the paper's 7x7x7 grid captured on a rig (Section III).

    python -m lab capture --rig twin --robot three-cable --grid 7 --out data/real_three_cable.csv
    python -m lab capture --rig twin:random:3 --design maximin --n 30 --seed 0 --out real30.csv
    python -m lab capture --rig twin --active 200 --batch 20 --out real_active.csv

Captures the safe commands of the grid (308 of 343 for 7 levels) -- or, with ``--sobol N``,
``--lhs N`` or ``--design D --n N``, ``N`` commands of a space-filling design over the safe
set (random, Sobol, maximin or Latin hypercube, ``lab.data.designs.design_commands``) --
with the protocol of ``lab.rig.capture`` into an append-only journal (default ``OUT``
with ``.journal.csv``), then writes the dataset ``OUT`` (+ ``OUT.json``) atomically, rows
in grid (or design) order, in the format ``lab.data.dataset.read_dataset`` reads.
With ``--active N --batch B`` it trains as it goes (``lab.learn.active``): each batch is
picked where an ensemble fitted to the samples so far disagrees most, journaled as a plan,
then captured; rows in capture order (``--order`` does not apply).
Killed or failed, it keeps every sample captured so far; the same command continues
where it stopped (an active run first finishes the batch it was in). On any error the
rig is closed (torque off on hardware) and the message names the problem.
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from pathlib import Path

import numpy as np

from lab.cli.paths import check_paths, check_writable, dataset_outputs, existing, ignore_file_size_signal
from lab.cli.sampling import add_sampler_args, check_sampler_args, sampler_words
from lab.cli.signals import exit_code
from lab.errors import InputError, LabError


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
        help="sim | twin[:DEFECTS.toml] | twin:random:SEED (an emulated as-built robot of the family) "
        "| hardware:RIG.toml (default: twin)",
    )
    p.add_argument("--robot", default="three-cable", help="shipped robot name or path to a TOML description")
    add_sampler_args(p)
    p.add_argument("--out", required=True, help="output CSV; metadata goes to OUT.json")
    p.add_argument("--journal", help="append-only journal to write or resume (default: OUT with .journal.csv)")
    p.add_argument(
        "--seed",
        type=int,
        default=0,
        help="seed of the design (or of --active's picks and ensembles), the shuffled order "
        "and the emulated rig's noise",
    )
    p.add_argument(
        "--order",
        choices=("shuffled", "grid"),
        default="shuffled",
        help="capture order (default shuffled; the dataset is written in grid/design order either way)",
    )
    p.add_argument(
        "--protocol",
        choices=("wait", "predictive"),
        default="wait",
        help="wait: the paper's protocol, record once settled (default); predictive: learn the foam's "
        "relaxation from the first samples, then record as soon as the settled tip is predicted within "
        "--predict-tol-mm (lab.rig.predictive)",
    )
    p.add_argument(
        "--predict-tol-mm",
        type=float,
        default=0.15,
        help="predictive: record when the predicted settled tip's 3-D standard deviation is below this, mm "
        "(default 0.15)",
    )
    p.add_argument(
        "--dynamic-model",
        help="predictive: a relaxation fitted by 'python -m lab fit-dynamics' (DYN.npz); skips the learning samples",
    )
    p.add_argument(
        "--no-wait", action="store_true", help="do not wait until settled: record 0.5 s after the motors arrive"
    )
    p.add_argument("--no-reset", action="store_true", help="do not erase hysteresis before each sample")
    p.add_argument("--settle-tol-mm", type=float, default=0.1, help="settle tolerance, mm (default 0.1)")
    p.add_argument(
        "--reset-rad", type=float, default=1.0, help="contraction of every cable in the reset, rad (default 1)"
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)
    return p


def command_line(args) -> str:
    """The command that reproduces ``args`` (for the dataset's metadata)."""
    words = [
        "python",
        "-m",
        "lab",
        "capture",
        "--rig",
        args.rig,
        "--robot",
        args.robot,
        *sampler_words(args),
        "--out",
        str(args.out),
        "--seed",
        str(args.seed),
        "--order",
        args.order,
    ]
    if args.journal:
        words += ["--journal", str(args.journal)]
    if args.protocol != "wait":
        words += ["--protocol", args.protocol, "--predict-tol-mm", repr(args.predict_tol_mm)]
        if args.dynamic_model:
            words += ["--dynamic-model", str(args.dynamic_model)]
    words += ["--no-wait"] * args.no_wait + ["--no-reset"] * args.no_reset
    if args.settle_tol_mm != 0.1:
        words += ["--settle-tol-mm", repr(args.settle_tol_mm)]
    if args.reset_rad != 1.0:
        words += ["--reset-rad", repr(args.reset_rad)]
    return shlex.join(words)


def rig_identity(description: dict) -> dict:
    """What must not change when a capture is resumed: rig kind, robot, mesh, and the
    hash of every configuration the rig reports (``{name: {"sha256": ...}}``)."""
    out = {k: description[k] for k in ("kind", "robot", "mesh") if k in description}
    out.update({f"{k}.sha256": v["sha256"] for k, v in description.items() if isinstance(v, dict) and "sha256" in v})
    return out


def _stats(a: np.ndarray) -> dict:
    return {
        "mean": float(np.mean(a)),
        "median": float(np.median(a)),
        "p95": float(np.percentile(a, 95)),
        "max": float(np.max(a)),
    }


def check_design_args(args) -> None:
    """Refuse a bad combination of sampling flags (:func:`lab.cli.sampling.check_sampler_args`)."""
    check_sampler_args(args)


def _commands(args, robot) -> tuple[np.ndarray, dict]:
    """The commands to capture (N, m) rad, in dataset order, and the sampler's metadata."""
    from lab.cli.sampling import fixed_commands

    u, sampler = fixed_commands(args, robot)
    return u, {**sampler, "order": args.order, "seed": args.seed}


def run(args) -> int:
    from lab.data.dataset import write_dataset
    from lab.description import load_robot
    from lab.rig import make_rig
    from lab.rig.capture import capture
    from lab.rig.protocol import Protocol

    check_design_args(args)
    journal = Path(args.journal) if args.journal else Path(args.out).with_suffix(".journal.csv")
    if args.protocol == "wait" and args.dynamic_model:
        raise InputError("--dynamic-model is for --protocol predictive")
    if not (args.predict_tol_mm > 0 and np.isfinite(args.predict_tol_mm)):
        raise InputError(f"--predict-tol-mm must be a positive number of mm, got {args.predict_tol_mm}")
    check_paths(
        {
            "--robot": existing(args.robot),
            "--rig": existing(args.rig.partition(":")[2] or None),
            "--dynamic-model": args.dynamic_model,
        },
        {**dataset_outputs("--out", args.out), "--journal": journal},
    )
    check_writable(args.out)
    check_writable(journal, "--journal")
    ignore_file_size_signal()
    try:
        robot = load_robot(args.robot)
        protocol = Protocol(
            wait=not args.no_wait,
            reset=not args.no_reset,
            settle_tol_m=1e-3 * args.settle_tol_mm,
            reset_u_rad=args.reset_rad,
            kind=args.protocol,
            predict_tol_m=1e-3 * args.predict_tol_mm,
        )
        relaxation = None
        if args.dynamic_model:
            from lab.learn.relaxation import load_relaxation

            relaxation = load_relaxation(args.dynamic_model)
        if args.active is None:
            grid, sampler = _commands(args, robot)
            order = (
                np.random.default_rng(args.seed).permutation(len(grid))
                if args.order == "shuffled"
                else np.arange(len(grid))
            )
            what = f"{args.design} design" if args.design else f"{args.grid}^{robot.n_cables} grid"
            what = f"{len(grid)} safe commands of the {what}"
        else:
            what = f"{args.active} safe commands picked actively in batches of {args.batch}"
        print(f"{robot.name}: {what} on rig {args.rig!r}, journal {journal}", file=sys.stderr)
        t0 = time.perf_counter()
        with make_rig(args.rig, robot, seed=args.seed) as rig:
            description = rig.describe()
            header = {"robot": {"name": robot.name, "sha256": robot.sha256}, "rig": rig_identity(description)}
            if args.active is not None:
                from lab.cli.capture_active import capture_active

                res, sampler = capture_active(args, robot, rig, protocol, journal, header, command_line(args))
                grid, order = res.u_motor, np.arange(len(res.u_motor))
            else:
                res = capture(
                    rig,
                    grid[order],
                    journal,
                    protocol,
                    header={**header, "sampler": sampler},
                    session_info={"command": command_line(args)},
                    progress=not args.no_progress,
                    relaxation=relaxation,
                )
        wall_s = time.perf_counter() - t0
    except KeyboardInterrupt as err:  # Ctrl-C, SIGTERM, SIGHUP: the rig is closed (torque off)
        why = f" by {err.args[0]}" if err.args else ""
        print(
            f"interrupted{why}; the rig was closed and every sample captured so far is in {journal}: "
            "run the same command again to continue",
            file=sys.stderr,
        )
        return exit_code(err)
    except (LabError, OSError):
        # the message itself is printed by lab.cli.main; the exit code follows the error
        if journal.exists():
            print(
                f"(the rig was closed; samples captured so far are in {journal}; "
                "the same command continues from there)",
                file=sys.stderr,
            )
        raise

    y = np.empty_like(res.p_tip_W)
    y[order] = res.p_tip_W  # back to grid (design) order
    settled = np.empty(len(grid), bool)
    settled[order] = res.settled
    per_sample = {name: np.empty(len(grid)) for name in ("sample_s", "settle_s")}
    for name, arr in per_sample.items():
        arr[order] = getattr(res, name)
    pred_std = np.empty(len(grid))
    pred_std[order] = res.pred_std_m
    unsettled = np.flatnonzero(~settled)
    learned = [info for tag, info in res.notes if tag == "relaxation"]
    meta = {
        "robot": {"name": robot.name, "sha256": robot.sha256, "description": robot.source},
        "rig": description,
        "protocol": protocol.as_dict(),
        "sampler": sampler,
        "capture": {
            "journal": str(journal),
            "n_sessions": int(res.session.max()),
            "n_unsettled": int(len(unsettled)) if protocol.wait else None,
            "unsettled_rows": unsettled.tolist() if protocol.wait else None,
            "robot_time_s": res.robot_time_s,
            "rate_samples_per_hour": res.rate_per_hour,
            "sample_s": _stats(res.sample_s),
            "settle_s": _stats(res.settle_s),
            "invalid_frame_fraction": float(res.n_invalid_frames.sum() / max(1, res.n_frames.sum())),
            "wall_s_this_session": wall_s,
            "wall_s_all_sessions": res.wall_s,
            "protocol": protocol.kind,
            **(
                {
                    "relaxation": learned[-1] if learned else {"from": str(args.dynamic_model)},
                    "n_predicted": int(res.predicted.sum()),
                    "pred_std_m": _stats(res.pred_std_m[res.predicted]) if res.predicted.any() else None,
                }
                if protocol.kind == "predictive"
                else {}
            ),
        },
        "per_sample": {
            "settled": settled.astype(int).tolist(),
            **{k: v.tolist() for k, v in per_sample.items()},
            **(
                {"pred_std_m": [None if np.isnan(v) else float(v) for v in pred_std]}
                if protocol.kind == "predictive"
                else {}
            ),
        },
        "command": command_line(args),
    }
    write_dataset(args.out, grid, y, meta)
    print(
        f"wrote {len(grid)} samples to {args.out} ({res.new_samples} new): {res.rate_per_hour:.0f} samples per "
        f"hour of robot time ({res.robot_time_s / 3600:.2f} h), {wall_s:.1f} s wall"
        + (f"; {len(unsettled)} not settled within {protocol.settle_timeout_s:g} s" if protocol.wait else "")
        + (f"; protocol {protocol.kind}, {int(res.predicted.sum())} predicted" if protocol.kind != "wait" else ""),
        file=sys.stderr,
    )
    return 0
