"""``python -m lab transfer-curve``: the sim-to-real curve over a family of emulated
as-built robots (issue 14; :mod:`lab.tracking.transfer_study`).

For each robot (``--family K``: members 0..K-1 of :func:`lab.rig.family.random_defects`,
plus ``--shipped`` for the shipped defects file), each method and each N it writes one row:
model error on held-out random commands and Table I tracking errors, in metres. Rows are
appended robot by robot (the file is rewritten atomically each time), so an interrupted run
resumes where it stopped; a robot whose rows are all there is skipped.
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

DEFAULT_NS = (0, 5, 10, 20, 30, 50, 100, 308)
COLUMNS = (
    "robot",
    "method",
    "n_real",
    "fit_s",
    "model_error_m",
    "circle_m",
    "square_m",
    "rose_m",
    "tracking_mean_m",
    "circle_size_ratio",
    "square_size_ratio",
    "rose_size_ratio",
    "size_ratio_mean",
    "shift_x_m",
    "shift_y_m",
    "shift_z_m",
)


def add_parser(subparsers, parents=()) -> argparse.ArgumentParser:
    """Add this command to an ``argparse`` subparsers object; returns its parser."""
    t = subparsers.add_parser(
        "transfer-curve",
        parents=parents,
        help="error against the number of real samples, per transfer method, over a family of as-built robots",
    )
    t.add_argument("--robot", default="three-cable", help="robot name or description TOML (default three-cable)")
    t.add_argument("--sim-model", required=True, help="network trained on simulated data (.npz)")
    t.add_argument("--family", type=int, default=10, help="family members 0..K-1 (default 10)")
    t.add_argument("--shipped", action="store_true", help="also the robot of the shipped defects file")
    t.add_argument(
        "--methods",
        nargs="+",
        default=["sim-only", "real-only", "finetune-last", "finetune", "residual"],
        help="transfer methods: sim-only, real-only, finetune-last, finetune, residual, calibrated (the last "
        "is slow: a calibration and a re-simulation of the lattice per N; default: all but calibrated)",
    )
    t.add_argument("--ns", type=int, nargs="+", default=list(DEFAULT_NS), help="numbers of real samples")
    t.add_argument("--design", choices=["random", "sobol", "maximin"], default="maximin", help="which N commands")
    t.add_argument("--n-test", type=int, default=100, help="held-out random commands per robot (default 100)")
    t.add_argument("--n-points", type=int, default=24, help="targets per trajectory (default 24)")
    t.add_argument("--seed", type=int, default=0, help="seed of designs, noise and training")
    t.add_argument("--n-rings", type=int, help="the emulated robots' FEM mesh (default: the defects' or robot's)")
    t.add_argument("--n-axial", type=int, help="the emulated robots' FEM mesh (default: the defects' or robot's)")
    t.add_argument(
        "--calibration-mesh",
        type=int,
        nargs=2,
        metavar=("RINGS", "AXIAL"),
        help="calibrated: mesh of calibration and re-simulation (default: the robot's)",
    )
    t.add_argument(
        "--sim-levels", type=int, default=7, help="calibrated: re-simulate the safe points of this lattice (default 7)"
    )
    t.add_argument("--jobs", type=int, default=default_jobs(), help="worker processes, one robot each")
    t.add_argument("--out", required=True, help="CSV, one row per (robot, method, N); resumed if it exists")
    t.set_defaults(func=run)
    return t


def study_robot(robot_spec: str, label: str, sim_model_path: str, args_d: dict, skip=frozenset()) -> list[dict]:
    """The rows of one robot but the (method, N) pairs in ``skip`` (runs in a worker process)."""
    from lab.data import design_commands
    from lab.description import load_robot
    from lab.learn.mlp import load_model
    from lab.rig.family import family_member
    from lab.rig.twin import AsBuiltBody
    from lab.tracking.transfer_study import curve_rows, make_methods, random_safe_commands
    from lab.workers import watch_parent

    watch_parent()
    robot = load_robot(robot_spec)
    seed = args_d["seed"]
    mesh = {"n_rings": args_d["n_rings"], "n_axial": args_d["n_axial"]}
    defects = family_member(robot, label, **mesh)  # drawn for the mesh it runs on
    body = AsBuiltBody(robot, defects, **mesh)
    sim_model = load_model(sim_model_path)
    ns = args_d["ns"]
    pool = design_commands(robot, max(max(ns), 1), args_d["design"], seed)
    u_test = random_safe_commands(robot, args_d["n_test"], seed + 1)
    extra = {"calibrated": _calibrated_builder(robot, args_d)} if "calibrated" in args_d["methods"] else None
    methods = make_methods(sim_model, args_d["methods"], seed=seed, extra=extra)
    rows = curve_rows(
        body,
        methods,
        ns,
        pool,
        u_test=u_test,
        noise_sigma_m=defects.noise_sigma_m,
        seed=seed,
        n_points=args_d["n_points"],
        label=label,
        skip=skip,
    )
    for r in rows:
        r["shift_x_m"], r["shift_y_m"], r["shift_z_m"] = r.pop("shift_mean_m")
        for s in ("circle", "square", "rose"):
            r.pop(f"{s}_shift_m", None)
    return rows


def _calibrated_builder(robot, args_d: dict):
    """``(u_real, y_real) -> model``: calibrated physics from 5 samples on; it re-simulates the
    safe points of the ``sim_levels`` lattice (the simulated dataset's commands)."""
    from lab.data.designs import grid_commands
    from lab.tracking.transfer_study import METHOD_MIN_N
    from lab.transfer.calibrated import calibrated_model

    u_sim = grid_commands(robot, args_d["sim_levels"])
    u_sim = u_sim[robot.is_safe(u_sim)]
    rings, axial = args_d["calibration_mesh"] or (robot.n_rings, robot.n_axial)

    def make(u, y):
        if len(u) < METHOD_MIN_N["calibrated"]:
            return None
        return calibrated_model(robot, u, y, u_sim, seed=args_d["seed"], n_rings=rings, n_axial=axial)

    return make


def _read_rows(path: Path) -> list[dict]:
    if not path.exists():
        return []
    with path.open(newline="") as fh:
        reader = csv.DictReader(fh)
        if reader.fieldnames is None or tuple(reader.fieldnames) != COLUMNS:
            raise InputError(f"{path}: not a transfer-curve file (columns {reader.fieldnames}); choose another --out")
        return list(reader)


def _write_rows(path: Path, rows: list[dict], meta: dict) -> None:
    from lab.files import atomic_write_group

    text = [",".join(COLUMNS)]
    for r in rows:
        text.append(",".join(str(r[c]) for c in COLUMNS))
    atomic_write_group({Path(f"{path}.json"): json.dumps(meta, indent=2) + "\n", path: "\n".join(text) + "\n"})


def _commands(out: Path, command: str) -> list[str]:
    """Every command that added rows to ``out``, oldest first (one file can hold several
    runs, e.g. the slow calibrated method added to a finished curve)."""
    side = Path(f"{out}.json")
    old = []
    if out.exists() and side.exists():
        try:
            meta = json.loads(side.read_text())
        except (OSError, ValueError):
            meta = {}
        old = meta.get("commands") or ([meta["command"]] if "command" in meta else [])
    return old + ([command] if command not in old else [])


def run(args) -> int:
    from joblib import Parallel, delayed, parallel_config

    from lab.files import code_version

    inputs = {"--sim-model": existing(args.sim_model)}
    if args.robot.endswith(".toml"):
        inputs["--robot"] = existing(args.robot)
    check_paths(inputs, {"--out": args.out, "--out sidecar": f"{args.out}.json"})
    check_writable(args.out)
    if args.calibration_mesh is not None:
        from lab.fem.mesh import check_mesh_size

        check_mesh_size(*args.calibration_mesh)
    if args.family < 0 or args.n_test < 1 or args.n_points < 2 or min(args.ns) < 0:
        raise InputError("--family >= 0, --n-test >= 1, --n-points >= 2 and --ns >= 0 are required")
    out = Path(args.out)
    rows = _read_rows(out)
    labels = (["shipped"] if args.shipped else []) + [f"random:{k}" for k in range(args.family)]
    from lab.tracking.transfer_study import expected_pairs

    want = expected_pairs(args.methods, args.ns)
    have = {lab: {(r["method"], int(r["n_real"])) for r in rows if r["robot"] == lab} for lab in labels}
    todo = [lab for lab in labels if not want <= have[lab]]
    print(f"{len(labels)} robots, {len(labels) - len(todo)} already in {out}", file=sys.stderr)
    keys = (
        "seed",
        "ns",
        "design",
        "n_test",
        "n_points",
        "methods",
        "n_rings",
        "n_axial",
        "calibration_mesh",
        "sim_levels",
    )
    args_d = {k: getattr(args, k) for k in keys}
    meta = {
        "kind": "lab.transfer_curve",
        "format_version": 1,
        "label": "emulated as-built robots (quasi-static settled tips, motion-capture noise on the real samples)",
        "robot": args.robot,
        "sim_model": args.sim_model,
        **args_d,
        "command": "python -m lab " + shlex.join(args.argv),
        "commands": _commands(out, "python -m lab " + shlex.join(args.argv)),
        "code_version": code_version(),
        "units": {"*_m": "m", "fit_s": "s"},
    }
    with parallel_config(backend="loky", inner_max_num_threads=1):
        runner = Parallel(n_jobs=min(args.jobs, max(1, len(todo))), return_as="generator_unordered")
        jobs = (delayed(study_robot)(args.robot, lab, args.sim_model, args_d, frozenset(have[lab])) for lab in todo)
        for new in runner(jobs):
            rows.extend(new)
            _write_rows(out, rows, meta)
            print(f"{new[0]['robot'] if new else '?'}: {len(new)} rows -> {out}", file=sys.stderr)
    return 0
