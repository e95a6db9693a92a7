"""Command-line interface: ``python -m lab simulate ...`` (later issues add commands)."""
from __future__ import annotations

import argparse
import shlex
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
        chunks = nearest_neighbour_chunks(u)
        sampler = {"name": "sobol", "n": args.sobol, "seed": args.seed, "scramble": True}
    else:
        u = grid_commands(robot, args.grid)
        chunks = grid_chunks(robot, u)
        sampler = {"name": "grid", "levels": args.grid, "n_candidates": args.grid ** robot.n_cables}
    sampler["n_safe"] = len(u)
    print(f"{robot.name}: {len(u)} safe commands, mesh n_rings={n_rings} n_axial={n_axial}, "
          f"{args.jobs} worker(s)", file=sys.stderr)
    res = simulate(robot, u, chunks, n_rings=n_rings, n_axial=n_axial, n_jobs=args.jobs,
                   progress=not args.no_progress)
    from .mesh import cylinder_mesh

    mesh = cylinder_mesh(robot.length_m, robot.radius_m, n_rings, n_axial)  # counts only
    meta = {
        "robot": {"name": robot.name, "sha256": robot.sha256, "description": robot.source},
        "mesh": {"mesher": "cylinder", "n_rings": n_rings, "n_axial": n_axial,
                 "n_nodes": mesh.n_nodes, "n_tets": len(mesh.tets)},
        "sampler": sampler,
        "solver": {"linear_solver": default_backend(), "mean_newton_iterations": float(res["iterations"].mean()),
                   "wall_s": res["wall_s"], "n_jobs": args.jobs},
        "command": "python -m lab " + shlex.join(sys.argv[1:]),
    }
    write_dataset(args.out, u, res["p_tip_W"], meta)
    print(f"wrote {len(u)} samples to {args.out} in {res['wall_s']:.1f} s "
          f"(mean {res['iterations'].mean():.2f} Newton iterations)", file=sys.stderr)
    return 0


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
    s.set_defaults(func=_simulate)
    return p


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    from .dataset import DatasetError
    from .description import DescriptionError

    try:
        return args.func(args)
    except (DescriptionError, DatasetError, ValueError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
