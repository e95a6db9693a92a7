"""``python -m lab inspect``: what a static model can reach on a dataset, before training one.

Reads a dataset (CSV + sidecar; measured sequences from its ``sequence_starts``), runs
:func:`lab.jobs.inspect.run` -- the repeatability floor, hysteresis, drift
over the measurement order and outliers -- writes the report as JSON (``--out``) and
prints a short summary. The flags are :class:`lab.data.diagnostics.InspectSpec`'s. What
each number means and assumes: ``docs/real-data.md``; the figure of a report:
:func:`lab.viz.real_data.plot_diagnostics`.
"""

from __future__ import annotations

import argparse
import shlex

from lab.cli.flags import add_spec_flags, spec_from_args
from lab.cli.paths import check_paths, check_writable, output_lock
from lab.cli.progress import Progress, add_progress_flag
from lab.data.diagnostics import InspectSpec
from lab.errors import InputError
from lab.jobs import inspect as job


def add_parser(subparsers, parents=()) -> argparse.ArgumentParser:
    """Add this command to an ``argparse`` subparsers object; returns its parser."""
    p = subparsers.add_parser(
        "inspect",
        parents=parents,
        help="what a static model can reach on a dataset: repeatability floor, hysteresis, drift, outliers",
    )
    p.add_argument("data", help="dataset CSV (u0..,x,y,z), e.g. data/asl_trunk_oct2024.csv")
    add_spec_flags(p, InspectSpec)
    p.add_argument("--out", required=True, help="the report (.json)")
    add_progress_flag(p)
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    spec = spec_from_args(InspectSpec, args)
    if not str(args.out).endswith(".json"):
        raise InputError(f"--out {args.out}: the report is JSON; give a file name ending in .json")
    check_paths(
        {"DATA": args.data, "DATA sidecar": f"{args.data}.json"}, {"--out": args.out, "--out lock": f"{args.out}.lock"}
    )
    check_writable(args.out)
    command = "python -m lab " + shlex.join(args.argv)
    with output_lock(args.out), Progress("step", enabled=not args.no_progress, at_most=True) as progress:
        report = job.run(spec, args.data, args.out, command=command, progress=progress.update)
    _print_summary(report)
    print(f"report -> {args.out}")
    return 0


def _mm(v) -> str:
    return "-" if v is None else f"{1e3 * v:.1f}"


def _print_summary(report: dict) -> None:
    f, h, d, o = (report[k] for k in ("floor", "hysteresis", "drift", "outliers"))
    unit = (report.get("dataset") or {}).get("u_unit") or "unit"
    print(f"{report['n_rows']} rows, {report['n_motors']} motors, {report['n_sequences']} sequence(s)")
    lo, hi = f["interval_m"] or (None, None)
    print(
        f"repeatability floor (RMS 3-D tip error of the best static model): {_mm(f['floor_m'])} mm "
        f"[{_mm(lo)}, {_mm(hi)}] from {f['n_pairs']} pairs ({f['n_exact_pairs']} exact revisits)"
        + (f"; {f['reason']}" if f.get("reason") else "")
    )
    for key in ("revisits", "same_sequence", "cross_sequence"):
        print(f"  {key.replace('_', ' ')}: {_mm(f[key]['floor_m'])} mm from {f[key]['n_pairs']} pairs")
    print(f"  a leave-one-out local fit reaches {_mm(o['residual_rms_m'])} mm RMS")
    for note in f.get("cautions", []):
        print(f"  caution: {note}")
    if h.get("fraction_explained") is None:
        print(f"hysteresis: not measured ({h.get('reason')})")
    else:
        print(
            f"hysteresis: the previous command explains {100 * h['fraction_explained']:.1f} % of the near pairs' "
            f"squared tip difference (p = {h['p_value']:.3f}); slope {_mm(h['slope_m_per_unit'])} mm per {unit}"
        )
    if d.get("rate_m_per_1000_rows") is None:
        print(f"drift: not measured ({d.get('reason')})")
    else:
        lo, hi = d["interval"]
        confounded = d["row_index_r2_from_command"] > 0.5
        print(
            f"drift within sequences: {_mm(d['rate_m_per_1000_rows'])} mm per 1000 rows [{_mm(lo)}, {_mm(hi)}]"
            + (" (the command order explains the row order: drift and map cannot be told apart)" if confounded else "")
        )
    print(f"outliers: {o['count']} rows beyond {_mm(o['threshold_m'])} mm from the local fit")
