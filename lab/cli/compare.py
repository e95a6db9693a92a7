"""``python -m lab compare``: every model side by side on one dataset, one resumable command.

Fits the least-squares baselines (``linear``, ``poly3``), the scikit-learn peers (``gpr``,
``knn``, ``sklearn-mlp``) and lab's networks (``mlp``, ``br``, ``ensemble``), each with
the history lengths asked for, on the same random, group (whole sequences) and sequential
(first 80 % of rows) splits of a dataset, and writes one row per fit to ``--out``
(:func:`lab.jobs.compare.run`, :mod:`lab.studies.model_comparison`; the flags are
:class:`lab.studies.comparison_spec.CompareSpec`'s). Rows are appended one by one, so an
interrupted run resumes where it stopped; a row already in the file is never fitted again,
and a file made from other data or with other settings is refused. ``--floor REPORT.json``
(an ``inspect`` report of the same data) adds each model's ratio to the repeatability
floor. The summary printed at the end: the mean test RMS per split, history and model.
"""

from __future__ import annotations

import argparse
import shlex

from lab.cli.flags import add_spec_flags, spec_from_args
from lab.cli.paths import check_paths, check_writable, output_lock
from lab.cli.progress import Progress, add_progress_flag
from lab.jobs import compare as job
from lab.studies.comparison_spec import CompareSpec
from lab.workers import default_jobs


def add_parser(subparsers, parents=()) -> argparse.ArgumentParser:
    """Add this command to an ``argparse`` subparsers object; returns its parser."""
    p = subparsers.add_parser(
        "compare", parents=parents, help="every model side by side on one dataset: test errors per split (resumable)"
    )
    p.add_argument("data", help="dataset CSV (u0..,x,y,z), e.g. data/asl_trunk_oct2024.csv")
    add_spec_flags(p, CompareSpec, default_words={"ns": "none"})
    p.add_argument("--floor", help="an inspect report of DATA: adds the ratio to its repeatability floor")
    p.add_argument(
        "--jobs", type=int, default=default_jobs(), help="worker processes, one fit each (default: the cores)"
    )
    p.add_argument("--out", required=True, help="CSV, one row per fit; resumed if it exists")
    add_progress_flag(p)
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    spec = spec_from_args(CompareSpec, args)
    inputs = {"DATA": args.data, "DATA sidecar": f"{args.data}.json", "--floor": args.floor}
    check_paths(inputs, {"--out": args.out, "--out sidecar": f"{args.out}.json", "--out lock": f"{args.out}.lock"})
    check_writable(args.out)
    command = "python -m lab " + shlex.join(args.argv)
    with output_lock(args.out), Progress("fit", enabled=not args.no_progress, parallel=args.jobs) as progress:
        side = job.run(spec, args.data, args.out, floor=args.floor, jobs=args.jobs, command=command,
                       log=progress.write, progress=progress.update)  # fmt: skip
    _print_summary(side)
    print(f"rows -> {args.out}")
    return 0


def _mm(v) -> str:
    return "-" if v is None or v != v else f"{1e3 * v:.1f}"


def _print_summary(side: dict) -> None:
    floor = side.get("floor")
    head = ("split", "K", "model", "splits", "RMS mm", "mean mm", "1sigma", "fit s")
    print("{:14s} {:>2s} {:12s} {:>6s} {:>7s} {:>7s} {:>6s} {:>7s}".format(*head) + (" /floor" if floor else ""))
    for r in side["summary"]:
        w = r["within_1sigma"]
        w1 = "-" if w is None or w != w else f"{w:.2f}"
        line = (
            f"{r['split']:14s} {r['history']:2d} {r['model']:12s} {r['n_splits']:6d} {_mm(r['test_rms_m']):>7s} "
            f"{_mm(r['test_mean_m']):>7s} {w1:>6s} {r['fit_s']:7.1f}"
        )
        print(line + (f" {r['ratio_to_floor']:.2f}" if floor and r["ratio_to_floor"] is not None else ""))
    if floor:
        print(f"repeatability floor {_mm(floor['floor_m'])} mm RMS (from {floor['report']})")
    for r in side.get("learning_curve") or []:
        print(f"learning curve: K={r['history']} {r['model']} N={r['n_train']}: {_mm(r['test_rms_m'])} mm RMS")
