"""Six-cable accuracy (issue 15, item 3): model error between lattice points and Figure 5 tracking.

    python benchmarks/bench_six_cable.py --model "grid 15,415, LM paper rules=data/model_sim_six_cable.npz" \
        --model "LABEL=MODEL.npz" ... [--heldout 400] [--out data/six_cable_accuracy.csv]

For each model (a forward model of the six-cable arm, any kind ``lab.learn.load_model``
reads) it prints and, with ``--out``, writes one row:

* ``test_split_mm``: the mean distance on the model's own test split (from its metadata;
  lattice points for a grid-trained model);
* ``between_lattice_mm``: the mean distance on ``--heldout`` random allowed commands
  (seeded, solved by the FEM on the description's default mesh: never lattice points);
* per Figure 5 path (``six-circle``, ``six-ring``, ``six-saddle``, ``six-spiral``, their
  default targets) the mean distance in cm between target and the tip the simulated
  robot settles at under the IK's commands (``lab.studies.evaluate_model``: the IK of
  ``python -m lab track`` with its defaults, the equilibria of the nominal FEM), their mean
  ``tracking_mean_cm`` and the targets the IK flagged unreachable.

The goal of the issue: ``tracking_mean_cm`` <= 0.05 with at most 31,000 samples. Rows
already in ``--out`` are kept (the study resumes by label); the sidecar ``OUT.json``
records every command that wrote rows.
"""

import argparse
import csv
import io
import json
import shlex
import sys
import time
from pathlib import Path

from lab.control.trajectories import SIX_CABLE
from lab.data import simulate
from lab.data.chunks import nearest_neighbour_chunks
from lab.data.designs import random_commands
from lab.description import load_robot
from lab.files import atomic_write_text, code_version
from lab.learn import load_model
from lab.studies import NominalBody, evaluate_model

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--model", action="append", required=True, metavar="LABEL=PATH", help="a model to measure")
parser.add_argument("--heldout", type=int, default=400, help="random held-out commands (default 400)")
parser.add_argument("--seed", type=int, default=12345, help="seed of the held-out commands")
parser.add_argument("--jobs", type=int, default=1, help="worker processes for the held-out solves")
parser.add_argument("--out", help="CSV to write (rows by label; existing rows are kept)")
args = parser.parse_args()

robot = load_robot("six-cable")
models = dict(spec.split("=", 1) for spec in args.model)
rows = []
if args.out and Path(args.out).exists():
    with open(args.out, newline="") as fh:
        rows = [r for r in csv.DictReader(fh) if r["configuration"] not in models]

t0 = time.perf_counter()
u_test = random_commands(robot, args.heldout, seed=args.seed)
tips_test = simulate(robot, u_test, nearest_neighbour_chunks(u_test, 50), n_jobs=args.jobs)["p_tip_W"]
print(f"{args.heldout} held-out random commands solved in {time.perf_counter() - t0:.0f} s", file=sys.stderr)
body = NominalBody(robot)
for label, path in models.items():
    model = load_model(path)
    training = model.metadata.get("training", {})
    t0 = time.perf_counter()
    ev = evaluate_model(model, body, u_test, tips_test, n_points=None, shapes=SIX_CABLE)
    row = {
        "configuration": label,
        "model": path,
        "n_samples": training.get("n_samples", ""),
        "layer_sizes": "-".join(map(str, getattr(model, "layer_sizes", []))),
        "epochs": training.get("epochs", ""),
        "test_split_mm": 1e3 * training.get("errors", {}).get("test", {}).get("mean_distance_m", float("nan")),
        "between_lattice_mm": 1e3 * ev["model_error_m"],
        **{f"{p}_mean_cm": 100 * ev[f"{p}_m"] for p in SIX_CABLE},
        "tracking_mean_cm": 100 * ev["tracking_mean_m"],
        "wall_s": time.perf_counter() - t0,
    }
    rows.append(row)
    print(
        f"{label}: N = {row['n_samples']}, test split {row['test_split_mm']:.3f} mm, between lattice points "
        f"{row['between_lattice_mm']:.3f} mm, tracking "
        + ", ".join(f"{p} {row[f'{p}_mean_cm']:.4f}" for p in SIX_CABLE)
        + f" cm; mean {row['tracking_mean_cm']:.4f} cm (goal <= 0.05)"
    )

if args.out:
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=list(rows[-1]), lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    sidecar = Path(f"{args.out}.json")
    meta = json.loads(sidecar.read_text()) if sidecar.exists() else {"commands": []}
    command = "python " + shlex.join(sys.argv)
    meta.update(
        {
            "kind": "lab.six_cable_accuracy",
            "format_version": 1,
            "heldout": {"n": args.heldout, "seed": args.seed, "mesh": "description default"},
            "units": {"*_mm": "mm", "*_cm": "cm", "wall_s": "s"},
            "code_version": code_version(),
        }
    )
    meta["commands"] = [c for c in meta["commands"] if c != command] + [command]
    atomic_write_text(args.out, buf.getvalue())
    atomic_write_text(sidecar, json.dumps(meta, indent=2) + "\n")
    print(f"rows -> {args.out}", file=sys.stderr)
