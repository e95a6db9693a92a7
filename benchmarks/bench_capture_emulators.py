"""Waited and predicted samples on the emulated bench that ``python -m lab.rig.emulators`` serves.

    python benchmarks/bench_capture_emulators.py [--n 13] [--body kinematic|asbuilt] [--wall] [--unsynced]

The whole hardware path (dynamixel-sdk and the NatNet client against the emulated XM430 bus
and NatNet server) captures ``--n`` random allowed commands with the waiting protocol and
with the predictive one (its first ``n_learn`` = 10 samples waited for while the relaxation
is learned, the rest predicted). The body is the ``KinematicBody`` the emulator command
serves (no foam lag, tip linear in the motor angles) or the as-built robot on the default
mesh (``--body asbuilt``). On the bench's virtual clock (robot time, frames: the same on an
idle or a loaded machine) unless ``--wall``. Per sample: robot time from the reset to the
record, frames read, error against the body's settled tip; and the learned relaxation.

``--unsynced`` puts back what the driver did before it scaled each servo's profile velocity to
its travel: every servo at the same speed, so the shorter travels end first and the tip
goes along a bent path (the cause of predicted samples ten times slower than waited ones).
"""

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

import lab.rig.dynamixel as dynamixel
from lab.capture.protocol import Protocol
from lab.capture.session import capture
from lab.data.designs import random_commands
from lab.description import load_robot
from lab.rig.emulators import EmulatedBench
from lab.rig.hardware import HardwareRig
from lab.rig.twin import AsBuiltBody


def run(robot, u, kind: str, args):
    body = AsBuiltBody(robot) if args.body == "asbuilt" else None
    with tempfile.TemporaryDirectory() as tmp, EmulatedBench(robot, body, virtual_time=not args.wall) as bench:
        cfg = bench.write_config(Path(tmp) / "rig.toml")
        with HardwareRig.from_config(cfg, robot, **bench.rig_options()) as rig:
            t0 = time.perf_counter()
            res = capture(rig, u, Path(tmp) / "j.csv", Protocol(kind=kind))
            wall = time.perf_counter() - t0
        body = bench.body
    truth = (
        np.array([body.quasi_static_tip(ui) for ui in u]) if args.body == "asbuilt" else body.p_rest_W + u @ body.J_W.T
    )
    err_mm = 1e3 * np.linalg.norm(res.p_tip_W - truth, axis=1)
    print(f"  {kind}: {len(u)} samples in {res.robot_time_s:.1f} s of robot time, {wall:.1f} s wall")
    for label, sel in (("waited", ~res.predicted), ("predicted", res.predicted)):
        if sel.any():
            print(
                f"    {label:>9}: {sel.sum():2d} samples, robot s/sample {res.sample_s[sel].mean():5.2f} "
                f"(min {res.sample_s[sel].min():.2f}, max {res.sample_s[sel].max():.2f}), frames/sample "
                f"{res.n_frames[sel].mean():6.0f}, not settled {int((~res.settled[sel]).sum())}, "
                f"error mean {err_mm[sel].mean():.3f} max {err_mm[sel].max():.3f} mm"
            )
    for tag, info in res.notes:
        if tag == "relaxation":
            print(
                f"    learned: tau {np.round(info['tau_s'], 4).tolist()} s, weight "
                f"{np.round(info['weight'], 4).tolist()}, noise {1e3 * info['noise_sigma_m']:.3f} mm per frame"
            )


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=13, help="commands per protocol (the first 10 learn)")
    ap.add_argument("--body", choices=("kinematic", "asbuilt"), default="kinematic")
    ap.add_argument("--wall", action="store_true", help="the wall clock instead of the bench's virtual clock")
    ap.add_argument("--unsynced", action="store_true", help="every servo at the same speed (the old driver)")
    ap.add_argument("--seed", type=int, default=11)
    args = ap.parse_args()
    if args.unsynced:
        dynamixel.synced_velocity_units = lambda travel, pace: np.full(len(travel), int(pace), dtype=np.int64)
    robot = load_robot("three-cable")
    u = random_commands(robot, args.n, seed=args.seed)
    clock = "wall clock" if args.wall else "virtual clock"
    servos = "every servo at the same speed" if args.unsynced else "servo speeds scaled to their travels"
    print(f"emulated bench, {args.body} body, {clock}, {servos}; {args.n} random commands (seed {args.seed})")
    for kind in ("wait", "predictive"):
        run(robot, u, kind, args)


if __name__ == "__main__":
    main()
