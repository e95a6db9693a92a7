"""Re-run robots of a cached sim-to-real curve with today's code and compare, cell by cell.

    python benchmarks/bench_transfer_rerun.py --robots random:0 random:1   # ~15 min, 2 cores

The cached curves (``data/transfer_curve.csv`` and ``..._foam.csv``) took hours; chapter 05
reads them. This script re-measures the rows of the named robots with the settings the
file's sidecar records (:func:`lab.studies.transfer_curve.study_robot`, one worker per robot)
and prints, per (robot, method, N), the cached and re-run tracking and model errors and the
largest relative difference. Equal rows mean the cache is what the code measures today.
"""

import argparse
import json
import time
from pathlib import Path

from joblib import Parallel, delayed

from lab.studies.transfer_curve import TransferCurveSpec, study_robot
from lab.studies.transfer_study import read_curve
from lab.workers import worker_config


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--curve", default="data/transfer_curve.csv")
    ap.add_argument("--robots", nargs="+", default=["random:0", "random:1"])
    ap.add_argument("--ns", type=int, nargs="+", help="only these N (default: all in the file)")
    ap.add_argument("--methods", nargs="+", help="only these methods (default: all in the file)")
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args()
    meta = json.loads(Path(f"{args.curve}.json").read_text())
    settings = meta  # the sidecar records the settings at its top level
    cached = [r for r in read_curve(args.curve) if r["robot"] in args.robots]
    methods = tuple(args.methods or dict.fromkeys(r["method"] for r in cached))
    ns = tuple(args.ns or sorted({r["n_real"] for r in cached}))
    kind = args.robots[0].split(":")[0]
    spec = TransferCurveSpec(
        sim_model=meta.get("sim_model", "data/model_sim_three_cable.npz"),
        robot=settings["robot"],
        family=0,
        family_kind=kind,
        methods=methods,
        ns=ns,
        design=settings["design"],
        n_test=settings["n_test"],
        n_points=settings["n_points"],
        seed=settings["seed"],
        sim_levels=settings.get("sim_levels", 7),
    )
    t0 = time.perf_counter()
    with worker_config():
        parts = Parallel(n_jobs=min(args.jobs, len(args.robots)))(
            delayed(study_robot)(spec, label) for label in args.robots
        )
    print(f"{args.curve}: {len(args.robots)} robots re-run in {time.perf_counter() - t0:.0f} s ({args.jobs} workers)")
    new = {(r["robot"], r["method"], r["n_real"]): r for p in parts for r in p}
    worst = 0.0
    head = f"{'robot':>9} {'method':>14} {'N':>4} {'tracking cm: cached':>20} {'re-run':>8}"
    print(head + f" {'model mm: cached':>17} {'re-run':>8}")
    for r in cached:
        key = (r["robot"], r["method"], r["n_real"])
        if r["method"] not in methods or r["n_real"] not in ns:
            continue
        n = new.get(key)
        if n is None:
            print(f"{key}: not re-measured")
            continue
        for k in ("tracking_mean_m", "model_error_m"):
            worst = max(worst, abs(n[k] - r[k]) / max(abs(r[k]), 1e-12))
        print(
            f"{key[0]:>9} {key[1]:>14} {key[2]:>4} {100 * r['tracking_mean_m']:20.4f} {100 * n['tracking_mean_m']:8.4f}"
            f" {1e3 * r['model_error_m']:17.3f} {1e3 * n['model_error_m']:8.3f}"
        )
    print(f"largest relative difference over the compared cells: {worst:.2e}")
    n_rows = sum(1 for r in cached if r["method"] in methods and r["n_real"] in ns)
    print(f"rows compared: {n_rows}; total {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
