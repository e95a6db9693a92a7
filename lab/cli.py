"""Command-line interface: ``python -m lab simulate|train|splits|track|capture ...``."""
from __future__ import annotations

import argparse
import shlex
import shutil
import sys

import numpy as np


def _simulate(args) -> int:
    from .dataset import write_dataset
    from .description import load_robot
    from .linsolve import default_backend
    from .sampling import grid_chunks, grid_commands, nearest_neighbour_chunks, simulate, sobol_commands

    robot = load_robot(args.robot)
    n_rings, n_axial = args.n_rings or robot.n_rings, args.n_axial or robot.n_axial
    if args.sobol is not None:
        u = sobol_commands(robot, args.sobol, seed=args.seed)
        chunks = nearest_neighbour_chunks(u, size=args.chunk_size)
        sampler = {"name": "sobol", "n": args.sobol, "seed": args.seed, "scramble": True}
    else:
        u = grid_commands(robot, args.grid)
        chunks = grid_chunks(robot, u, target_size=args.chunk_size)
        sampler = {"name": "grid", "levels": args.grid, "n_candidates": args.grid ** robot.n_cables}
    sampler["n_safe"] = len(u)
    print(f"{robot.name}: {len(u)} safe commands, mesh n_rings={n_rings} n_axial={n_axial}, "
          f"{args.jobs} worker(s)", file=sys.stderr)
    checkpoint = args.checkpoint or f"{args.out}.chunks"
    if args.restart:
        shutil.rmtree(checkpoint, ignore_errors=True)
    res = simulate(robot, u, chunks, n_rings=n_rings, n_axial=n_axial, n_jobs=args.jobs,
                   progress=not args.no_progress, checkpoint=checkpoint, scheduler=args.scheduler)
    if res["resumed_samples"]:
        print(f"resumed: {res['resumed_samples']} samples came from {checkpoint}", file=sys.stderr)
    from .mesh import cylinder_mesh

    mesh = cylinder_mesh(robot.length_m, robot.radius_m, n_rings, n_axial)  # counts only
    meta = {
        "robot": {"name": robot.name, "sha256": robot.sha256, "description": robot.source},
        "mesh": {"mesher": "cylinder", "n_rings": n_rings, "n_axial": n_axial,
                 "n_nodes": mesh.n_nodes, "n_tets": len(mesh.tets)},
        "sampler": sampler,
        "solver": {"linear_solver": default_backend(), "mean_newton_iterations": float(res["iterations"].mean()),
                   "wall_s": res["wall_s"], "n_jobs": args.jobs, "scheduler": args.scheduler,
                   "resumed_samples": res["resumed_samples"]},
        "command": "python -m lab " + shlex.join(sys.argv[1:]),
    }
    write_dataset(args.out, u, res["p_tip_W"], meta)
    shutil.rmtree(checkpoint, ignore_errors=True)  # the dataset now holds every chunk
    print(f"wrote {len(u)} samples to {args.out} in {res['wall_s']:.1f} s "
          f"(mean {res['iterations'].mean():.2f} Newton iterations)", file=sys.stderr)
    return 0


def _train(args) -> int:
    import hashlib
    import json
    from pathlib import Path

    from .dataset import atomic_write_text, code_version, read_dataset
    from .evaluate import workspace_size_m
    from .train import LMOptions, train

    u, y, meta = read_dataset(args.data)
    if any(h < 1 for h in args.hidden):
        raise ValueError(f"--hidden widths must be positive, got {args.hidden}")
    if args.epochs is not None and args.epochs < 1:
        raise ValueError(f"--epochs must be positive, got {args.epochs}")
    options = LMOptions(min_grad=args.min_grad) if args.algorithm == "lm" and args.min_grad is not None else None
    print(f"{args.data}: {len(u)} samples, {u.shape[1]} inputs -> {y.shape[1]} outputs; training "
          f"{'-'.join(map(str, [u.shape[1], *args.hidden, y.shape[1]]))} ({args.activation}) with "
          f"{args.algorithm}, split {args.split}, seed {args.seed}", file=sys.stderr)
    res = train(u, y, args.hidden, activation=args.activation, algorithm=args.algorithm, ratios=args.split,
                seed=args.seed, epochs=args.epochs, options=options)
    file_sha = hashlib.sha256(Path(args.data).read_bytes()).hexdigest()
    training = res.model.metadata["training"]
    training["data"] = {"path": str(args.data), "file_sha256": file_sha,
                        "robot": (meta.get("robot") or {}).get("name")}
    training["command"] = "python -m lab " + shlex.join(args.argv)
    res.model.save(args.out)
    size = workspace_size_m(y) or float("nan")
    print(f"stopped: {training['stop_message']} after {res.log.epochs} epochs (best epoch "
          f"{res.log.best_epoch}), {res.log.wall_s:.2f} s")
    print(f"{'set':<11}{'n':>5}{'MSE [m^2]':>13}{'mean dist [mm]':>16}{'% of workspace':>16}")
    for name, err in res.errors.items():
        if err["n"]:
            print(f"{name:<11}{err['n']:>5}{err['mse_m2']:>13.3e}{1e3 * err['mean_distance_m']:>16.4f}"
                  f"{100 * err['mean_distance_m'] / size:>16.4f}")
        else:
            print(f"{name:<11}{0:>5}{'-':>13}{'-':>16}{'-':>16}")
    print(f"workspace size (bounding-box diagonal of the tip data): {1e3 * size:.1f} mm; model -> {args.out}")
    if args.report:
        report = {"kind": "lab.train_report", "format_version": 1, **res.errors,
                  "workspace_size_m": size if np.isfinite(size) else None,
                  "model": str(args.out), "data": str(args.data),
                  "data_file_sha256": file_sha, "data_sha256": training["data_sha256"],
                  "layer_sizes": list(res.model.layer_sizes), "activation": args.activation,
                  "algorithm": args.algorithm, "seed": args.seed, "split": list(args.split),
                  "stop_reason": res.log.stop_reason, "epochs": res.log.epochs,
                  "best_epoch": res.log.best_epoch, "wall_s": res.log.wall_s, "code_version": code_version()}
        atomic_write_text(args.report, json.dumps(report, indent=2) + "\n")
    return 0


def _splits(args) -> int:
    from .dataset import read_dataset
    from .evaluate import evaluate_splits, summarize, workspace_size_m, write_csv
    from .train import LMOptions

    u, y, _ = read_dataset(args.data)
    if any(h < 1 for h in args.hidden) or args.n_splits < 1 or args.jobs < 1:
        raise ValueError("--hidden widths, --n-splits and --jobs must be positive")
    print(f"{args.data}: {len(u)} samples; {args.n_splits} random splits {args.split} of a "
          f"{'-'.join(map(str, [u.shape[1], *args.hidden, y.shape[1]]))} network, seed {args.seed}, "
          f"{args.jobs} worker(s)", file=sys.stderr)
    options = LMOptions(min_grad=args.min_grad) if args.min_grad is not None else None
    rows = evaluate_splits(u, y, args.hidden, n_splits=args.n_splits, ratios=tuple(args.split), seed=args.seed,
                           n_jobs=args.jobs, options=options)
    for r in rows:
        r["command"] = "python -m lab " + shlex.join(args.argv)
    write_csv(args.out, rows)
    size = workspace_size_m(y)
    for s in summarize(rows, "hidden", "test_mean_distance_m"):
        print(f"test mean distance over {s['n']} splits: {1e3 * s['mean']:.4f} mm (std {1e3 * s['std']:.4f}), "
              f"{100 * s['mean'] / size:.3f} % of the {1e3 * size:.1f} mm workspace")
    mse = summarize(rows, "hidden", "test_mse_m2")[0]
    print(f"test MSE: {mse['mean']:.3e} m^2; rows -> {args.out}")
    return 0


def _track(args) -> int:
    from .track import track_main

    return track_main(args)


def build_parser() -> argparse.ArgumentParser:
    from .sampling import default_jobs

    p = argparse.ArgumentParser(prog="python -m lab", description=__doc__)
    sub = p.add_subparsers(dest="command", required=True)
    s = sub.add_parser("simulate", help="simulate (u, y) pairs of a robot with the FEM and write a dataset")
    s.add_argument("--robot", default="three-cable", help="shipped robot name or path to a TOML description")
    g = s.add_mutually_exclusive_group()
    g.add_argument("--grid", type=int, default=7, metavar="LEVELS", help="grid levels per motor (default 7)")
    g.add_argument("--sobol", type=int, metavar="N", help="N scrambled-Sobol samples instead of a grid")
    s.add_argument("--seed", type=int, default=0, help="seed of the Sobol scrambling")
    s.add_argument("--n-rings", type=int, help="override the description's mesh rings")
    s.add_argument("--n-axial", type=int, help="override the description's mesh layers")
    s.add_argument("--jobs", type=int, default=default_jobs(), help="worker processes (default: all cores)")
    s.add_argument("--out", required=True, help="output CSV; metadata goes to OUT.json")
    s.add_argument("--no-progress", action="store_true", help="no progress bar")
    s.add_argument("--checkpoint", metavar="DIR",
                   help="where finished chunks are kept until the dataset is written (default OUT.chunks); "
                        "running the same command again after a kill resumes from it")
    s.add_argument("--chunk-size", type=int, default=64,
                   help="commands per chunk (a unit of work and of checkpointing; default 64)")
    s.add_argument("--restart", action="store_true", help="discard an existing checkpoint and start over")
    s.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                   help="run the chunks on this Dask scheduler instead of local worker processes")
    s.set_defaults(func=_simulate)

    t = sub.add_parser("train", help="train the forward model u -> y (an MLP) on a dataset")
    t.add_argument("data", help="dataset CSV (u0..,x,y,z), e.g. data/sim_three_cable.csv")
    t.add_argument("--hidden", type=int, nargs="+", default=[20, 20], metavar="WIDTH",
                   help="hidden layer widths (default: 20 20)")
    t.add_argument("--out", required=True, help="output model file (.npz)")
    t.add_argument("--report", help="also write the train/validation/test errors as JSON here")
    t.add_argument("--split", type=float, nargs=3, default=[0.8, 0.1, 0.1], metavar=("TRAIN", "VAL", "TEST"),
                   help="random split ratios like MATLAB dividerand (default: 0.8 0.1 0.1)")
    t.add_argument("--seed", type=int, default=0, help="seed of the split and the initial weights")
    t.add_argument("--activation", choices=["tanh", "logistic"], default="tanh", help="hidden activation")
    t.add_argument("--algorithm", choices=["lm", "adam", "lbfgs"], default="lm",
                   help="Levenberg-Marquardt (MATLAB trainlm, default), Adam or L-BFGS")
    t.add_argument("--epochs", type=int, help="maximum epochs (default 1000)")
    t.add_argument("--min-grad", type=float, help="LM: gradient stop (default 1e-6; 0 disables)")
    t.set_defaults(func=_train)

    e = sub.add_parser("splits", help="accuracy over random splits: train a network on each, report test errors")
    e.add_argument("data", help="dataset CSV (u0..,x,y,z)")
    e.add_argument("--hidden", type=int, nargs="+", default=[20, 20], metavar="WIDTH",
                   help="hidden layer widths (default: 20 20)")
    e.add_argument("--n-splits", type=int, default=10, help="number of random splits (default 10)")
    e.add_argument("--split", type=float, nargs=3, default=[0.9, 0.0, 0.1], metavar=("TRAIN", "VAL", "TEST"),
                   help="split ratios (default 0.9 0 0.1, as the paper's Section V-A study)")
    e.add_argument("--seed", type=int, default=0, help="seed the split seeds are derived from")
    e.add_argument("--min-grad", type=float, help="LM gradient stop (default 1e-6, the paper's)")
    e.add_argument("--jobs", type=int, default=default_jobs(), help="worker processes (default: all cores)")
    e.add_argument("--out", required=True, help="CSV, one row per split (lab.evaluate.evaluate_splits keys)")
    e.set_defaults(func=_splits)

    k = sub.add_parser("track", help="follow a trajectory on a rig with IK through a model (or Soft IK)")
    src = k.add_mutually_exclusive_group(required=True)
    src.add_argument("--model", help="learned forward model (.npz) to solve the IK through")
    src.add_argument("--soft-ik", action="store_true", help="Soft IK: solve the IK through the FEM instead")
    k.add_argument("--rig", default="sim", help="sim | twin[:DEFECTS.toml] | hardware:CONFIG.toml (default sim)")
    k.add_argument("--robot", default="three-cable", help="shipped robot name or path to a TOML description")
    k.add_argument("--trajectory", required=True,
                   help="circle, square, rose, helix (three-cable), six-circle, six-ring, six-saddle, six-spiral "
                        "(six-cable), or a CSV file with header x,y,z (metres, frame W)")
    k.add_argument("--n-points", type=int, help="points of a built-in trajectory (default: its own)")
    k.add_argument("--solver", choices=["lm", "gd"], default="lm",
                   help="bounded Levenberg-Marquardt (default) or projected gradient descent")
    k.add_argument("--reg-weight", type=float, default=0.0,
                   help="regulariser towards the previous command, m^2/rad^2 (default 0)")
    k.add_argument("--posture-weight", type=float, default=0.0,
                   help="regulariser towards the centre of the allowed commands (keeps a redundant "
                        "arm's cables taut), m^2/rad^2 (default 0); regularised answers are polished")
    k.add_argument("--seed", type=int, default=0, help="noise seed of an emulated rig")
    k.add_argument("--n-rings", type=int, help="FEM mesh rings of --rig sim / --soft-ik (default: robot's)")
    k.add_argument("--n-axial", type=int, help="FEM mesh layers of --rig sim / --soft-ik (default: robot's)")
    k.add_argument("--out", required=True, help="result JSON")
    k.set_defaults(func=_track)

    from .capture_cli import add_capture_parser

    add_capture_parser(sub)
    return p


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    args.argv = list(sys.argv[1:] if argv is None else argv)
    from .dataset import DatasetError
    from .description import DescriptionError
    from .model import ModelFileError

    try:
        return args.func(args)
    except (DescriptionError, DatasetError, ModelFileError, ValueError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
