"""Calibration recovery and coverage over both families of emulated as-built robots.

    python benchmarks/bench_calibration_family.py --out data/calibration_family.csv   # ~25 min, 2 cores

For members 0..K-1 of ``twin:random`` (in the calibrator's model class but for play and axial
eyelet shifts) and ``twin:foam`` (the same in-class defects plus the hyperfoam law, base tilt,
mocap frame error, cable compliance, creep and a finer mesh), each robot is sampled at N
maximin commands (settled tips plus its own mocap noise, :func:`lab.rig.twin.quasi_static_tips`)
and the nominal description is calibrated to them on its own mesh, declaring the robot's true
noise (a lab measures it from a static recording). One row per (robot, parameter):
:func:`lab.transfer.recovery.recovery_rows` with ``play_as_slack`` plus ``family``. Rows are
kept by robot, so an interrupted run resumes. Chapter 05 reads the file.

Per family it prints the coverage of the 2-sigma intervals (raw and Birge-inflated), how
often ``calibrate``'s chi-square flag fires, and the number of robots whose intervals hold
the truth for under 90 % of their parameters *without* being flagged (the goal: none).
"""

import argparse
import shlex
import sys
import time
from pathlib import Path

import numpy as np
from joblib import Parallel, delayed

from lab.data.designs import design_commands
from lab.description import load_robot
from lab.files import code_version
from lab.transfer.recovery import read_recovery, recovery_rows, robot_coverage, summary_table, write_recovery
from lab.workers import worker_config


def robot_rows(robot_name: str, label: str, n: int, seed: int) -> list[dict]:
    from lab.asbuilt.family import family_member

    robot = load_robot(robot_name)
    u = design_commands(robot, n, "maximin", seed)
    d = family_member(robot, label)  # the member on its own mesh (foam: finer than the fit's)
    rows = recovery_rows(robot, d, u, label=label, seed=seed, noise_m=d.noise_sigma_m, play_as_slack=True)
    return [{"family": label.split(":")[0], **r} for r in rows]


def report(rows: list[dict]) -> None:
    for family in dict.fromkeys(r["family"] for r in rows):
        rs = [r for r in rows if r["family"] == family]
        robots = robot_coverage(rs)
        err = np.array([r["recovered"] - r["true"] for r in rs])
        raw, inf = (np.array([r[k] for r in rs]) for k in ("std_raw", "std_inflated"))
        fits = {r["robot"]: r for r in rs}.values()
        chi2 = np.array([f["reduced_chi2"] for f in fits])
        ratio = np.median([f["rms_m"] / f["expected_rms_m"] for f in fits])
        silent = [k for k, (c, flag) in robots.items() if c < 0.9 and not flag]
        print(
            f"\n{family}: {len(robots)} robots, N = {rs[0]['n_real']}\n"
            f"  flag fires {sum(f for _, f in robots.values())}/{len(robots)}; reduced chi2 median "
            f"{np.median(chi2):.2f} (min {chi2.min():.2f}, max {chi2.max():.3g}); RMS residual / expected "
            f"median {ratio:.2f}\n"
            f"  within 2 std, all {len(err)} parameters: raw {np.mean(np.abs(err) <= 2 * raw):.1%}, "
            f"inflated {np.mean(np.abs(err) <= 2 * inf):.1%}\n"
            f"  robots under 90% coverage (inflated) and not flagged: {len(silent)} {silent}"
        )
        print(summary_table(rs))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robot", default="three-cable")
    ap.add_argument("--family", type=int, default=10, help="members 0..K-1 of each family")
    ap.add_argument("--kinds", nargs="+", default=["random", "foam"], choices=["random", "foam"])
    ap.add_argument("--n", type=int, default=30, help="maximin samples per robot")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", type=Path, help="CSV (robots already in it are kept)")
    args = ap.parse_args()
    if not 1 <= args.family <= 50 or not 5 <= args.n <= 400 or not 1 <= args.jobs <= 16:
        sys.exit("--family 1..50, --n 5..400, --jobs 1..16")
    rows = []
    if args.out and args.out.exists():
        rows = read_recovery(args.out)
        if any(r["n_real"] != args.n for r in rows):
            sys.exit(f"{args.out}: made with another --n; choose another --out")
    done = {r["robot"] for r in rows}
    labels = [f"{k}:{i}" for k in args.kinds for i in range(args.family) if f"{k}:{i}" not in done]
    print(f"{len(labels)} robots to calibrate, {len(done)} already in {args.out}", flush=True)
    meta = {
        "what": "calibration recovery per (robot, parameter) on the random and foam families",
        "command": "python " + shlex.join(sys.argv),
        "code_version": code_version(),
        "settings": {"robot": args.robot, "n": args.n, "seed": args.seed, "design": "maximin"},
    }
    t0 = time.perf_counter()
    with worker_config():
        for i in range(0, len(labels), args.jobs):
            chunk = labels[i : i + args.jobs]
            parts = Parallel(n_jobs=len(chunk))(delayed(robot_rows)(args.robot, k, args.n, args.seed) for k in chunk)
            rows += [r for p in parts for r in p]
            if args.out:
                write_recovery(args.out, rows, meta)
            print(f"  {', '.join(chunk)} done at {time.perf_counter() - t0:.0f} s", flush=True)
    rows.sort(key=lambda r: (["random", "foam"].index(r["family"]), int(r["robot"].split(":")[1])))
    if args.out:
        write_recovery(args.out, rows, meta)
    report(rows)


if __name__ == "__main__":
    main()
