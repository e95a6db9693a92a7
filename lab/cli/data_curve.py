"""``python -m lab data-curve``: model and tracking error against the number of samples N,
per sampling strategy (issue 15; :mod:`lab.tracking.data_curve`).

For one robot on one rig (``sim``: the nominal FEM; ``twin``, ``twin:DEFECTS.toml``,
``twin:random:SEED``: an emulated as-built robot), each strategy and each N it writes one
row: the model error on a common held-out set of random allowed commands, the Table I
tracking errors (unless ``--no-tracking``), the fit time and the capture hours at the
measured rate. Rows are appended one by one (the file and its sidecar are rewritten
atomically), so an interrupted run resumes where it stopped; a (strategy, N) already in
the file is never measured again. A file is only resumed with the settings it was made
with (robot, rig, model, mesh, held-out set, ...). One row per (strategy, N, seed):
``--seeds 0 1 2`` repeats each with other designs, noise and initial weights.
"""

from __future__ import annotations

import argparse
import csv
import json
import shlex
import sys
from pathlib import Path

from lab.cli.paths import check_paths, check_writable, existing
from lab.errors import InputError
from lab.workers import default_jobs

DEFAULT_NS = (25, 50, 100, 200, 308)
#: The capture rate of the shipped dataset, in case its sidecar is not at hand: samples per
#: hour of robot time of ``capture --rig twin --grid 7`` (data/real_three_cable.csv.json).
FALLBACK_SAMPLES_PER_HOUR = 290.35
DEFAULT_RATE_FROM = "data/real_three_cable.csv"
COLUMNS = (
    "robot",
    "rig",
    "rig_spec",
    "strategy",
    "n",
    "grid_levels",
    "seed",
    "model",
    "model_error_m",
    "circle_m",
    "square_m",
    "rose_m",
    "tracking_mean_m",
    "fit_s",
    "design_s",
    "capture_h",
    "heldout_id",
)
#: What a file is resumed with only if it was made with the same.
SETTINGS = ("robot", "rig", "model", "hidden", "epochs", "heldout_seed", "heldout", "n_rings", "n_axial", "batch",
            "tracking", "n_points", "samples_per_hour", "algorithm", "n_initial")  # fmt: skip
#: The value of a setting added later, in files made before it.
SETTING_DEFAULTS = {"algorithm": "lm", "n_initial": None}


def add_parser(subparsers, parents=()) -> argparse.ArgumentParser:
    """Add this command to an ``argparse`` subparsers object; returns its parser."""
    p = subparsers.add_parser(
        "data-curve",
        parents=parents,
        help="model and tracking error against the number of samples, per sampling strategy",
    )
    p.add_argument("--robot", default="three-cable", help="robot name or description TOML (default three-cable)")
    p.add_argument("--rig", default="sim", help="sim | twin[:DEFECTS.toml] | twin:random:SEED (default sim)")
    p.add_argument(
        "--strategies",
        nargs="+",
        default=None,
        help="grid sobol lhs maximin random active (default: all but active that this install has)",
    )
    p.add_argument("--ns", type=int, nargs="+", default=list(DEFAULT_NS), help="numbers of samples N")
    p.add_argument(
        "--grid-levels",
        type=int,
        nargs="+",
        help="grid: these levels per motor (default: the safe count nearest each N)",
    )
    p.add_argument("--model", default="mlp", help="mlp (default), ensemble, gpr, knn, sklearn-mlp")
    p.add_argument("--hidden", type=int, nargs="+", default=[20, 20], help="hidden layer widths (default 20 20)")
    p.add_argument("--epochs", type=int, help="maximum training epochs (default: the trainer's)")
    p.add_argument(
        "--algorithm",
        default="lm",
        help="training: lm (default; the paper's stopping rules), br (Bayesian), adam, lbfgs",
    )
    p.add_argument("--heldout", type=int, default=200, help="held-out random allowed commands (default 200)")
    p.add_argument(
        "--seeds", type=int, nargs="+", default=[0], help="seeds of designs, noise and training: a row per seed"
    )
    p.add_argument("--heldout-seed", type=int, default=1, help="seed of the held-out commands (default 1)")
    p.add_argument("--batch", type=int, default=25, help="active: samples per batch (default 25)")
    p.add_argument("--n-initial", type=int, help="active: initial Sobol design (default: max(2 batch, 10 motors))")
    p.add_argument("--n-points", type=int, default=24, help="targets per trajectory (default 24)")
    p.add_argument("--no-tracking", action="store_true", help="model error only (no Table I tracking)")
    p.add_argument("--n-rings", type=int, help="the FEM mesh of the robot (default: the description's)")
    p.add_argument("--n-axial", type=int, help="the FEM mesh of the robot (default: the description's)")
    p.add_argument("--samples-per-hour", type=float, help="capture rate for capture_h (default: --rate-from's)")
    p.add_argument(
        "--rate-from",
        default=DEFAULT_RATE_FROM,
        help=f"dataset whose sidecar's capture.rate_samples_per_hour is used (default {DEFAULT_RATE_FROM})",
    )
    p.add_argument("--jobs", type=int, default=default_jobs(), help="worker processes, one row each")
    p.add_argument("--out", required=True, help="CSV, one row per (strategy, N, seed); resumed if it exists")
    p.set_defaults(func=run)
    return p


def capture_rate(args) -> tuple[float, str]:
    """(samples per hour, where the number comes from)."""
    if args.samples_per_hour is not None:
        if not args.samples_per_hour > 0:
            raise InputError(f"--samples-per-hour must be positive, got {args.samples_per_hour}")
        return float(args.samples_per_hour), "--samples-per-hour"
    side = Path(args.rate_from if str(args.rate_from).endswith(".json") else f"{args.rate_from}.json")
    if not side.exists() and args.rate_from == DEFAULT_RATE_FROM:  # run outside the repository
        side = Path(__file__).resolve().parents[2] / f"{DEFAULT_RATE_FROM}.json"
    if not side.exists():
        if args.rate_from != DEFAULT_RATE_FROM:
            raise InputError(f"--rate-from {args.rate_from}: no sidecar {side}")
        return FALLBACK_SAMPLES_PER_HOUR, f"{side} capture.rate_samples_per_hour (built-in copy; file not found)"
    try:
        meta = json.loads(side.read_text())
        rate = float(meta["capture"]["rate_samples_per_hour"])
    except (ValueError, KeyError, TypeError):
        raise InputError(f"--rate-from {side}: no capture.rate_samples_per_hour in it") from None
    rig = meta.get("rig", {}).get("kind", "?") if isinstance(meta.get("rig"), dict) else meta.get("rig", "?")
    src = f"{DEFAULT_RATE_FROM}.json" if args.rate_from == DEFAULT_RATE_FROM else str(side)
    return rate, f"{src} capture.rate_samples_per_hour (rig {rig}, the waiting protocol)"


def _read(path: Path) -> tuple[list[dict], dict]:
    if not path.exists():
        return [], {}
    with path.open(newline="") as fh:
        reader = csv.DictReader(fh)
        if reader.fieldnames is None or tuple(reader.fieldnames) != COLUMNS:
            raise InputError(f"{path}: not a data-curve file (columns {reader.fieldnames}); choose another --out")
        rows = list(reader)
    side = Path(f"{path}.json")
    meta = json.loads(side.read_text()) if side.exists() else {}
    return rows, meta


def read_data_curve(path) -> list[dict]:
    """Rows of a ``data-curve`` CSV; numbers as floats (``n`` and ``seed`` as int, ``grid_levels`` int or None)."""
    rows, _ = _read(Path(path))
    text = ("robot", "rig", "rig_spec", "strategy", "model", "heldout_id")
    for r in rows:
        for k, v in r.items():
            if k in ("n", "seed"):
                r[k] = int(v)
            elif k == "grid_levels":
                r[k] = int(v) if v else None
            elif k not in text:
                r[k] = float(v)
    return rows


def _write(path: Path, rows: list[dict], meta: dict) -> None:
    from lab.files import atomic_write_group

    text = [",".join(COLUMNS)] + [",".join(str(r[c]) for c in COLUMNS) for r in rows]
    atomic_write_group({Path(f"{path}.json"): json.dumps(meta, indent=2) + "\n", path: "\n".join(text) + "\n"})


_BODIES: dict = {}


def _body(robot_spec: str, rig: str, n_rings, n_axial):
    """The robot's body, built once per process (its equilibrium cache is reused)."""
    from lab.description import load_robot
    from lab.tracking.data_curve import make_body

    key = (robot_spec, rig, n_rings, n_axial)
    if key not in _BODIES:
        _BODIES[key] = make_body(load_robot(robot_spec), rig, n_rings=n_rings, n_axial=n_axial)
    return _BODIES[key]


def measure_row(robot_spec: str, rig: str, mesh: tuple, heldout, plan: tuple, kw: dict) -> dict:
    """One row, ``plan`` = (strategy, n, levels, seed) (runs in this process or a worker)."""
    from lab.tracking.data_curve import data_curve_row

    body, label, noise = _body(robot_spec, rig, *mesh)
    strategy, n, levels, seed = plan
    row = data_curve_row(body, strategy, n, levels, heldout=heldout, noise_sigma_m=noise, seed=seed, **kw)
    return {"robot": body.robot.name, "rig": label, "rig_spec": rig, **row}


def run(args) -> int:
    from lab.files import code_version
    from lab.tracking.data_curve import check_model, check_strategies, heldout_set, plan_rows

    inputs = {"--robot": existing(args.robot) if args.robot.endswith(".toml") else None}
    check_paths(inputs, {"--out": args.out, "--out sidecar": f"{args.out}.json"})
    check_writable(args.out)
    if min(args.seeds) < 0 or args.heldout_seed < 0:
        raise InputError("--seeds and --heldout-seed must be integers >= 0")
    if min(args.ns) < 1 or args.heldout < 1 or args.batch < 1 or args.n_points < 2 or args.jobs < 1:
        raise InputError("--ns >= 1, --heldout >= 1, --batch >= 1, --n-points >= 2 and --jobs >= 1 are required")
    if args.epochs is not None and args.epochs < 1 or min(args.hidden) < 1:
        raise InputError("--epochs and --hidden widths must be positive")
    from lab.learn.train import ALGORITHMS

    if args.algorithm not in ALGORITHMS:
        raise InputError(f"--algorithm must be one of {', '.join(ALGORITHMS)}, got {args.algorithm!r}")
    if args.n_initial is not None and args.n_initial < 1:
        raise InputError("--n-initial must be >= 1")
    if args.n_rings is not None or args.n_axial is not None:
        from lab.description import load_robot as _load
        from lab.fem.mesh import check_mesh_size

        r = _load(args.robot)
        check_mesh_size(args.n_rings or r.n_rings, args.n_axial or r.n_axial)
    if args.strategies is None:
        from lab.data.designs import DESIGNS

        args.strategies = [s for s in ("grid", "sobol", "lhs", "maximin", "random") if s == "grid" or s in DESIGNS]
    strategies = check_strategies(args.strategies)
    check_model(args.model)
    rate, rate_source = capture_rate(args)
    settings = {k: getattr(args, k) for k in SETTINGS if k not in ("tracking", "samples_per_hour")}
    settings.update(tracking=not args.no_tracking, samples_per_hour=rate)
    out = Path(args.out)
    rows, old = _read(out)
    if rows and old.get("settings") is not None:
        was = {k: old["settings"].get(k, SETTING_DEFAULTS.get(k)) for k in SETTINGS}
        diff = [k for k in SETTINGS if json.dumps(was[k]) != json.dumps(settings[k])]
        if diff:
            raise InputError(f"{out} was made with other settings ({', '.join(diff)}); choose another --out")

    body, label, noise = _body(args.robot, args.rig, args.n_rings, args.n_axial)
    heldout = heldout_set(body, args.heldout, args.heldout_seed)
    if any(r["heldout_id"] != heldout[2] for r in rows):
        raise InputError(f"{out} was measured on another held-out set; choose another --out")
    have = {(r["strategy"], int(r["n"]), int(r["seed"])) for r in rows}
    plan = [
        (*p, seed)
        for seed in dict.fromkeys(args.seeds)
        for p in plan_rows(body.robot, strategies, args.ns, args.grid_levels)
        if (*p[:2], seed) not in have
    ]
    print(f"{len(plan)} rows to measure, {len(have)} already in {out}", file=sys.stderr)
    command = "python -m lab " + shlex.join(args.argv)
    commands = old.get("commands", []) if rows else []
    meta = {
        "kind": "lab.data_curve",
        "format_version": 1,
        "label": f"{label}: quasi-static settled tips"
        + (f", motion-capture noise {noise:g} m per axis on the samples" if noise else ", no noise"),
        "settings": settings,
        "noise_sigma_m": noise,
        "samples_per_hour_source": rate_source,
        "heldout": {"n": args.heldout, "seed": args.heldout_seed, "id": heldout[2], "tips": "settled, no noise"},
        "model_recipe": "mlp: lab.learn.train, LM with the paper's stopping rules, 90/10 train/validation split"
        if args.model == "mlp" and args.algorithm == "lm"
        else f"lab.learn.models.fit_model({args.model!r}, algorithm={args.algorithm!r})",
        "command": command,
        "commands": commands + ([command] if command not in commands else []),
        "code_version": code_version(),
        "units": {"*_m": "m", "fit_s": "s", "design_s": "s", "capture_h": "h"},
    }
    kw = {"model": args.model, "hidden": tuple(args.hidden), "epochs": args.epochs, "algorithm": args.algorithm,
          "batch": args.batch, "n_initial": args.n_initial, "tracking": not args.no_tracking,
          "n_points": args.n_points, "samples_per_hour": rate}  # fmt: skip
    mesh = (args.n_rings, args.n_axial)
    if args.jobs == 1 or len(plan) <= 1:
        results = (measure_row(args.robot, args.rig, mesh, heldout, p, kw) for p in plan)
        _collect(results, rows, out, meta)
        return 0
    from joblib import Parallel, delayed, parallel_config

    with parallel_config(backend="loky", inner_max_num_threads=1):
        runner = Parallel(n_jobs=min(args.jobs, len(plan)), return_as="generator_unordered")
        _collect(
            runner(delayed(measure_row)(args.robot, args.rig, mesh, heldout, p, kw) for p in plan), rows, out, meta
        )
    return 0


def _collect(results, rows: list[dict], out: Path, meta: dict) -> None:
    for row in results:
        rows.append(row)
        _write(out, rows, meta)
        track = (
            f", tracking {100 * row['tracking_mean_m']:.3f} cm"
            if row["tracking_mean_m"] == row["tracking_mean_m"]
            else ""
        )
        print(
            f"{row['strategy']} N={row['n']}: model error {1000 * row['model_error_m']:.3f} mm{track} -> {out}",
            file=sys.stderr,
        )
    if not rows or not out.exists():
        _write(out, rows, meta)
