"""``python -m lab transfer``: a forward model for the real arm from simulated data and N
real samples (issue 14), by one of the methods of :mod:`lab.learn.transfer`, or by
calibrated physics (:mod:`lab.transfer.calibrated`: the FEM is calibrated to the real
samples and re-simulates the commands of ``--sim``, and a network is trained on those).

The real samples come from ``capture`` on any rig (``twin``, ``twin:random:SEED``,
``hardware:RIG.toml``): the method sees only the dataset, so hardware data work exactly
as emulated data. The model written is one ``.npz`` that ``track --model`` accepts
(a residual model too).
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys

from lab.cli.paths import check_paths, check_writable, existing
from lab.errors import InputError

METHODS = ("real-only", "finetune", "finetune-last", "residual", "calibrated")


def add_parser(subparsers, parents=()) -> argparse.ArgumentParser:
    """Add this command to an ``argparse`` subparsers object; returns its parser."""
    t = subparsers.add_parser(
        "transfer",
        parents=parents,
        help="a forward model for the real arm from simulated data and a few real samples",
        description="Train a model for the real arm from a simulated dataset (--sim) and N real samples "
        "(--real): real-only (the N samples alone), finetune / finetune-last (the simulation network, "
        "fine-tuned with a prior towards its weights chosen by cross-validation), residual (the "
        "simulation network plus a Gaussian-process model of the difference), calibrated (the FEM's "
        "as-built parameters fitted to the real samples, the --sim commands re-simulated on it, a network "
        "trained on those).",
    )
    t.add_argument("--method", required=True, choices=METHODS, help="transfer method")
    t.add_argument("--sim", help="simulated dataset CSV (e.g. data/sim_three_cable.csv): a network is trained on it")
    t.add_argument("--sim-model", help="instead of --sim: a network already trained on simulation (.npz)")
    t.add_argument("--real", required=True, help="real dataset CSV (from `capture`)")
    t.add_argument("--robot", help="robot name or description TOML; checked against the datasets' robots")
    t.add_argument("--out", required=True, help="output model file (.npz)")
    t.add_argument(
        "--hidden", type=int, nargs="+", default=[20, 20], metavar="WIDTH", help="hidden widths (default: 20 20)"
    )
    t.add_argument("--seed", type=int, default=0, help="seed of the splits, initial weights and GP restarts")
    t.add_argument(
        "--n-rings", type=int, help="calibrated: mesh rings of calibration and re-simulation (default: the robot's)"
    )
    t.add_argument(
        "--n-axial", type=int, help="calibrated: mesh layers of calibration and re-simulation (default: the robot's)"
    )
    t.add_argument("--jobs", type=int, default=1, help="calibrated: worker processes of the re-simulation (default 1)")
    t.set_defaults(func=run)
    return t


def _check_robot(robot, meta: dict, what: str) -> None:
    name = (meta.get("robot") or {}).get("name")
    if robot is not None and name is not None and name != robot.name:
        raise InputError(f"{what} was made on robot {name!r}, but --robot is {robot.name!r}")


def run(args) -> int:
    from lab.data.dataset import read_dataset
    from lab.description import load_robot
    from lab.learn.mlp import load_model
    from lab.learn.train import train
    from lab.learn.transfer import transfer_model

    if args.method == "calibrated" and (args.sim is None or args.sim_model is not None or args.robot is None):
        raise InputError(
            "--method calibrated needs --robot R and --sim SIM.csv (its commands are re-simulated), not --sim-model"
        )
    if args.method != "calibrated" and (args.n_rings is not None or args.n_axial is not None):
        raise InputError("--n-rings/--n-axial are options of --method calibrated only")
    if args.method != "real-only" and (args.sim is None) == (args.sim_model is None):
        raise InputError(f"--method {args.method} needs exactly one of --sim SIM.csv and --sim-model SIM.npz")
    inputs = {"--real": existing(args.real), "--real sidecar": f"{args.real}.json"}
    for flag, path in (("--sim", args.sim), ("--sim-model", args.sim_model)):
        if path is not None:
            inputs[flag] = existing(path)
    if args.sim:
        inputs["--sim sidecar"] = f"{args.sim}.json"
    if args.robot and args.robot.endswith(".toml"):
        inputs["--robot"] = existing(args.robot)
    check_paths(inputs, {"--out": args.out})
    check_writable(args.out)
    if any(h < 1 for h in args.hidden):
        raise InputError(f"--hidden widths must be positive, got {args.hidden}")
    robot = load_robot(args.robot) if args.robot else None
    u_real, y_real, meta_real = read_dataset(args.real)
    _check_robot(robot, meta_real, f"--real {args.real}")
    if args.method == "calibrated":
        return _run_calibrated(args, robot, u_real, y_real)
    sim_model = None
    if args.method != "real-only":
        if args.sim_model:
            sim_model = load_model(args.sim_model)
        else:
            u_sim, y_sim, meta_sim = read_dataset(args.sim)
            _check_robot(robot, meta_sim, f"--sim {args.sim}")
            print(f"training {args.hidden} on {len(u_sim)} simulated samples ({args.sim})", file=sys.stderr)
            sim_model = train(u_sim, y_sim, args.hidden, seed=args.seed).model
        if (sim_model.n_u, sim_model.n_y) != (u_real.shape[1], y_real.shape[1]):
            raise InputError(
                f"the simulation network maps {sim_model.n_u} -> {sim_model.n_y}, the real data "
                f"{u_real.shape[1]} -> {y_real.shape[1]}"
            )
    print(f"{args.method}: {len(u_real)} real samples from {args.real}", file=sys.stderr)
    model = transfer_model(args.method, u_real, y_real, sim_model, hidden=tuple(args.hidden), seed=args.seed)
    model.metadata["transfer"].update(
        {
            "real": str(args.real),
            "sim": args.sim,
            "sim_model": args.sim_model,
            "command": "python -m lab " + shlex.join(args.argv),
        }
    )
    return _finish(args, model, u_real, y_real)


def _finish(args, model, u_real, y_real) -> int:
    import numpy as np

    model.save(args.out)
    fit_mm = 1e3 * float(np.mean(np.linalg.norm(model.predict(u_real) - y_real, axis=1)))
    print(json.dumps({"method": args.method, "n_real": len(u_real), "fit_mean_distance_mm": fit_mm, "model": args.out}))
    return 0


def _run_calibrated(args, robot, u_real, y_real) -> int:
    from lab.data.dataset import read_dataset
    from lab.fem.mesh import check_mesh_size
    from lab.transfer.calibrated import calibrated_model

    n_rings = robot.n_rings if args.n_rings is None else args.n_rings
    n_axial = robot.n_axial if args.n_axial is None else args.n_axial
    check_mesh_size(n_rings, n_axial)
    if args.jobs < 1:
        raise InputError(f"--jobs must be positive, got {args.jobs}")
    if u_real.shape[1] != robot.n_cables:
        raise InputError(f"{args.real}: {u_real.shape[1]} motor columns, but {robot.name} has {robot.n_cables} cables")
    u_sim, _, meta_sim = read_dataset(args.sim)
    _check_robot(robot, meta_sim, f"--sim {args.sim}")
    print(
        f"calibrated: {len(u_real)} real samples from {args.real}; mesh n_rings={n_rings} n_axial={n_axial}; "
        f"then {len(u_sim)} commands of {args.sim} re-simulated",
        file=sys.stderr,
    )
    try:
        model = calibrated_model(
            robot,
            u_real,
            y_real,
            u_sim,
            hidden=tuple(args.hidden),
            seed=args.seed,
            n_rings=n_rings,
            n_axial=n_axial,
            n_jobs=args.jobs,
            log=lambda line: print(line, file=sys.stderr),
        )
    except InputError as err:
        raise InputError(f"{args.real}: {err}") from None
    model.metadata["transfer"].update(
        {"real": str(args.real), "sim": args.sim, "command": "python -m lab " + shlex.join(args.argv)}
    )
    return _finish(args, model, u_real, y_real)
