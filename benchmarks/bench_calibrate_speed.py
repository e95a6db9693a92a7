"""Calibration speed: ``lab.transfer.calibrate``'s Levenberg-Marquardt loop and sensitivities
against the loop before it (``algorithm="marquardt"``, kept as the reference), interleaved in
one process.

    python benchmarks/bench_calibrate_speed.py            # 15 to 40 min on 2 shared cores
    python benchmarks/bench_calibrate_speed.py --robots shipped random:0 random:1 --quick-repeats 1

Part 1, chapter 05's calibration recovery cell in full mode, robot by robot (the cell's own
settings: the robot's settled tips plus its mocap noise at 30 maximin commands, seed 0,
calibrated on the description's mesh at the default declared noise, as
``lab.transfer.recovery.recovery_rows``): each robot calibrated by both loops in turn (which
goes first alternates), ``--repeats`` times. Per robot: process CPU time (median), LM
iterations, trials, rejected trials, static solves and Hessian factorisations (the solves' and
the sensitivities'); and whether the results agree: the largest |theta_new - theta_ref| in the
reported std, the largest change of a std, the chi-square flags.

Part 2, the cell in quick mode as the notebook runs it (``family_recovery`` with the notebook's
parameters: random:0 and random:1 on the 2 x 8 mesh), in this process (``n_jobs=1``, so that its
CPU time holds all of it), both loops alternating, ``--quick-repeats`` times.

CPU time, not wall time: the machine is shared (load average printed). Ratios are new / reference.
"""

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse  # noqa: E402
import platform  # noqa: E402
import shlex  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from lab.asbuilt.family import family_member  # noqa: E402
from lab.data.designs import design_commands  # noqa: E402
from lab.description import load_robot  # noqa: E402
from lab.rig.twin import AsBuiltBody, quasi_static_tips  # noqa: E402
from lab.transfer import calibrate, family_recovery  # noqa: E402
from lab.transfer.levenberg import ALGORITHMS  # noqa: E402

NEW, REF = ALGORITHMS


def load() -> str:
    return " ".join(f"{v:.2f}" for v in os.getloadavg())


def cpu(fn):
    t0 = time.process_time()
    out = fn()
    return out, time.process_time() - t0


def robot_part(robot, labels, repeats: int) -> dict:
    u = design_commands(robot, 30, "maximin", 0)
    print(f"\nPart 1: full mode, robot by robot ({robot.n_rings} rings x {robot.n_axial} layers, 30 maximin samples)")
    print(
        f"  {'robot':<10}{'loop':<14}{'CPU s':>7}{'iters':>6}{'trials':>7}{'rejected':>9}{'solves':>7}"
        f"{'factorisations':>15}{'RMS mm':>8}{'flag':>6}"
    )
    totals = {a: 0.0 for a in ALGORITHMS}
    counts = {a: np.zeros(5, int) for a in ALGORITHMS}
    worst = {"theta": 0.0, "std": 0.0, "flags": 0}
    for k, label in enumerate(labels):
        d = family_member(robot, label)
        y = quasi_static_tips(AsBuiltBody(robot, d), u, d.noise_sigma_m, 0)
        times, fits = {a: [] for a in ALGORITHMS}, {}
        for r in range(repeats):
            for a in ALGORITHMS if (k + r) % 2 == 0 else ALGORITHMS[::-1]:
                fits[a], t = cpu(lambda a=a, y=y: calibrate(robot, u, y, algorithm=a))
                times[a].append(t)
        for a in ALGORITHMS:
            f, t = fits[a], float(np.median(times[a]))
            totals[a] += t
            c = (f.iterations, f.n_trials, f.n_rejected, f.n_solves, f.n_factorisations)
            counts[a] += c
            flag = f.check["model_discrepancy"]
            print(
                f"  {label:<10}{a:<14}{t:7.1f}{c[0]:6d}{c[1]:7d}{c[2]:9d}{c[3]:7d}{c[4]:15d}"
                f"{1e3 * f.rms_m:8.4f}{'yes' if flag else 'no':>6}"
            )
        new, ref = fits[NEW], fits[REF]
        dtheta = float(np.max(np.abs(new.theta - ref.theta) / ref.std))
        dstd = float(np.max(np.abs(new.std / ref.std - 1)))
        same = new.check["model_discrepancy"] == ref.check["model_discrepancy"]
        worst = {
            "theta": max(worst["theta"], dtheta),
            "std": max(worst["std"], dstd),
            "flags": worst["flags"] + (not same),
        }
        print(
            f"  {'':<10}new / ref: CPU {np.median(times[NEW]) / np.median(times[REF]):.2f}; "
            f"|theta_new - theta_ref| <= {dtheta:.4f} std; std within {100 * dstd:.2f} %; flags "
            f"{'agree' if same else 'DIFFER'}",
            flush=True,
        )
    print(f"  all {len(labels)} robots:")
    for a in ALGORITHMS:
        c = counts[a]
        print(
            f"    {a:<14}CPU {totals[a]:7.1f} s; {c[0]} iterations, {c[1]} trials ({c[2]} rejected), "
            f"{c[3]} solves, {c[4]} factorisations"
        )
    print(
        f"    new / ref: CPU {totals[NEW] / totals[REF]:.2f}, trials {counts[NEW][1] / counts[REF][1]:.2f}, "
        f"rejected {counts[NEW][2]} vs {counts[REF][2]}, factorisations {counts[NEW][4] / counts[REF][4]:.2f}; "
        f"largest |theta_new - theta_ref| {worst['theta']:.4f} std, std within {100 * worst['std']:.2f} %, "
        f"flags differ on {worst['flags']} robots"
    )
    return totals


def quick_part(robot, repeats: int) -> dict:
    u = design_commands(robot, 30, "maximin", 0)
    labels = ["random:0", "random:1"]
    print("\nPart 2: the recovery cell in quick mode (family_recovery, random:0 and random:1, 2 x 8 mesh, n_jobs=1)")
    times, rows = {a: [] for a in ALGORITHMS}, {}
    for r in range(repeats):
        for a in ALGORITHMS if r % 2 == 0 else ALGORITHMS[::-1]:
            rows[a], t = cpu(
                lambda a=a: family_recovery(robot, labels, u, seed=0, n_rings=2, n_axial=8, n_jobs=1, algorithm=a)
            )
            times[a].append(t)
            print(f"  {a:<14}CPU {t:6.1f} s", flush=True)
    med = {a: float(np.median(times[a])) for a in ALGORITHMS}
    err = max(abs(n["recovered"] - o["recovered"]) / o["std"] for n, o in zip(rows[NEW], rows[REF]) if o["std"] > 0)
    print(
        f"  median CPU: {NEW} {med[NEW]:.1f} s, {REF} {med[REF]:.1f} s; new / ref {med[NEW] / med[REF]:.2f}; "
        f"recovered values agree within {err:.4f} std"
    )
    return med


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", nargs="+", default=["shipped"] + [f"random:{k}" for k in range(10)])
    ap.add_argument("--repeats", type=int, default=1, help="calibrations per robot and loop (part 1)")
    ap.add_argument("--quick-repeats", type=int, default=3, help="recovery cells per loop (part 2)")
    args = ap.parse_args()
    print("python " + shlex.join(sys.argv))
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, {platform.python_version()}; load average {load()}")
    robot = load_robot("three-cable")
    t0 = time.perf_counter()
    robot_part(robot, args.robots, args.repeats)
    if args.quick_repeats:
        quick_part(robot, args.quick_repeats)
    print(f"\nload average at the end {load()}; wall {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
