"""Capture on a foam robot: what creep over minutes does to both protocols (chapter 09).

    python benchmarks/bench_foam_capture.py --out data/capture_foam0.csv   # ~4 min, 1 core

The same ``--n`` random allowed commands are captured on ``--rig twin:foam:SEED`` (the
hyperfoam law, tilt, frame error, stretching cables and a third lag mode of minutes: creep),
first by waiting (the paper's protocol) and then predictively (``capture --protocol
predictive``), each on a fresh rig with the repeat check on (:func:`lab.capture.session.capture`).
Per protocol: samples per hour of robot time, the mean distance from the tip the robot
settles to after a long hold (:meth:`lab.rig.twin.AsBuiltBody.quasi_static_tip`, every
mode relaxed), the mean distance of the predicted samples from the waited ones (same
command, same history), the learned relaxation, and the repeat check. One row per protocol
in ``--out`` (+ ``.json`` with this command); the printout is ``bench_foam_capture.txt``.
"""

import argparse
import csv
import io
import json
import shlex
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from lab.asbuilt.family import family_member
from lab.capture.repeat_check import repeat_check_line
from lab.capture.session import capture
from lab.data.designs import random_commands
from lab.description import load_robot
from lab.files import atomic_write_text, code_version
from lab.rig.twin import AsBuiltBody, TwinRig
from lab.studies.capture_rate import protocol_for

COLUMNS = [
    "robot", "protocol", "tol_m", "n", "rate_per_hour", "rate_after_learning_per_hour", "mean_error_m",
    "max_error_m", "mean_from_waited_m", "repeat_distance_m", "repeat_threshold_m", "drift", "tau_s", "weight",
    "true_tau_s", "true_weight",
]  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rig", default="twin:foam:0", help="twin:foam:SEED or twin:random:SEED")
    ap.add_argument("--n", type=int, default=100, help="random allowed commands")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path)
    args = ap.parse_args()
    label = args.rig.removeprefix("twin:")
    if not 12 <= args.n <= 1000:
        sys.exit("--n 12..1000 (the predictive protocol learns from the first 10)")
    robot = load_robot("three-cable")
    d = family_member(robot, label)
    u = random_commands(robot, args.n, seed=args.seed)
    body = AsBuiltBody(robot, d)
    t0 = time.perf_counter()
    truth = np.array([body.quasi_static_tip(ui) for ui in u])
    true_tau = [d.tau_fast_s, d.tau_slow_s] + ([d.creep_tau_s] if d.creep_fraction > 0 else [])
    true_w = [1 - d.slow_fraction - d.creep_fraction, d.slow_fraction] + (
        [d.creep_fraction] if d.creep_fraction > 0 else []
    )
    print(f"{args.rig}: {args.n} random allowed commands; lag tau {true_tau} s, weights {np.round(true_w, 3).tolist()}")
    rows, waited = [], None
    for kind, tol in (("wait", 1e-4), ("predictive", 1.5e-4)):
        rig = TwinRig(robot, body=AsBuiltBody(robot, d), seed=args.seed)
        protocol = protocol_for(kind, tol)
        with tempfile.TemporaryDirectory() as tmp:
            res = capture(rig, u, Path(tmp) / "journal.csv", protocol, repeat_check=True)
        err = np.linalg.norm(res.p_tip_W - truth, axis=1)
        after = res.predicted if kind == "predictive" else np.ones(len(u), bool)
        learned = [info for tag, info in res.notes if tag == "relaxation"]
        rc = res.repeat_check
        row = {
            "robot": label,
            "protocol": kind,
            "tol_m": tol,
            "n": len(u),
            "rate_per_hour": res.rate_per_hour,
            "rate_after_learning_per_hour": 3600.0 * after.sum() / res.sample_s[after].sum(),
            "mean_error_m": float(err.mean()),
            "max_error_m": float(err.max()),
            "mean_from_waited_m": float("nan")
            if waited is None
            else float(np.linalg.norm(res.p_tip_W - waited, axis=1)[after].mean()),
            "repeat_distance_m": rc["distance_m"],
            "repeat_threshold_m": rc["threshold_m"],
            "drift": rc["drift"],
            "tau_s": " ".join(f"{v:.4g}" for v in learned[-1]["tau_s"]) if learned else "",
            "weight": " ".join(f"{v:.4g}" for v in learned[-1]["weight"]) if learned else "",
            "true_tau_s": " ".join(f"{v:.4g}" for v in true_tau),
            "true_weight": " ".join(f"{v:.4g}" for v in true_w),
        }
        waited = res.p_tip_W if waited is None else waited
        rows.append(row)
        print(
            f"  {kind:>10}: {row['rate_per_hour']:5.0f} samples/h ({row['rate_after_learning_per_hour']:.0f} after "
            f"learning); from the long-hold tip mean {1e3 * row['mean_error_m']:.3f} mm, max "
            f"{1e3 * row['max_error_m']:.3f} mm"
            + ("" if kind == "wait" else f"; from the waited samples mean {1e3 * row['mean_from_waited_m']:.3f} mm")
            + (f"; learned tau {row['tau_s']} s, weight {row['weight']}" if learned else "")
            + f"\n              {repeat_check_line(res)}",
            flush=True,
        )
    print(f"total {time.perf_counter() - t0:.0f} s")
    if args.out:
        buf = io.StringIO()
        w = csv.DictWriter(buf, fieldnames=COLUMNS, lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
        atomic_write_text(args.out, buf.getvalue())
        meta = {"command": "python " + shlex.join(sys.argv), "code_version": code_version(), "rig": args.rig}
        atomic_write_text(f"{args.out}.json", json.dumps(meta, indent=2) + "\n")
        print(f"-> {args.out}")


if __name__ == "__main__":
    main()
