"""``python -m lab transfer``: a forward model for the real arm from simulated data and N
real samples, by a method of :mod:`lab.transfer.data_methods` or by calibrated physics
(:mod:`lab.transfer.calibrated`: the FEM is calibrated to the real samples and re-simulates
the commands of ``--sim``, and a network is trained on those).

The flags are those of :class:`lab.jobs.transfer.TransferSpec`; :func:`lab.jobs.transfer.run`
builds the model. The real samples come from ``capture`` on any rig (``twin``,
``twin:random:SEED``, ``hardware:RIG.toml``): the method sees only the dataset. The model
written is one ``.npz`` that ``track --model`` accepts (a residual model too).
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys

from lab.cli.flags import add_spec_flags, spec_from_args
from lab.cli.paths import check_paths, check_writable, existing
from lab.fem.bodies.mesh_spec import MeshSpec
from lab.jobs import transfer as job
from lab.jobs.transfer import TransferSpec, fit_mean_distance_mm
from lab.learn.train_spec import TrainSpec

MESH_HELP = {
    "n_rings": "calibrated: mesh rings of calibration and re-simulation",
    "n_axial": "calibrated: mesh layers of calibration and re-simulation",
}


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
    add_spec_flags(t, TransferSpec)
    add_spec_flags(
        t, TrainSpec, only=("hidden", "seed"), help={"seed": "seed of the splits, initial weights and GP restarts"}
    )
    add_spec_flags(t, MeshSpec, help=MESH_HELP, default_words={"n_rings": "the robot's", "n_axial": "the robot's"})
    t.add_argument("--out", required=True, help="output model file (.npz)")
    t.set_defaults(func=run)
    return t


def run(args) -> int:
    spec = spec_from_args(
        TransferSpec, args, train=spec_from_args(TrainSpec, args), mesh=spec_from_args(MeshSpec, args)
    )
    inputs = {"--real": existing(spec.real), "--real sidecar": f"{spec.real}.json"}
    for flag, path in (("--sim", spec.sim), ("--sim-model", spec.sim_model)):
        if path is not None:
            inputs[flag] = existing(path)
    if spec.sim:
        inputs["--sim sidecar"] = f"{spec.sim}.json"
    if spec.robot and spec.robot.endswith(".toml"):
        inputs["--robot"] = existing(spec.robot)
    check_paths(inputs, {"--out": args.out})
    check_writable(args.out)
    model, (u_real, y_real) = job.run(
        spec, command="python -m lab " + shlex.join(args.argv), log=lambda line: print(line, file=sys.stderr)
    )
    model.save(args.out)
    fit_mm = fit_mean_distance_mm(model, u_real, y_real)
    print(json.dumps({"method": spec.method, "n_real": len(u_real), "fit_mean_distance_mm": fit_mm, "model": args.out}))
    return 0
