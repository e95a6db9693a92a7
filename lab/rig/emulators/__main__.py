"""Serve an emulated hardware bench until interrupted, and write its rig configuration.

    python -m lab.rig.emulators --robot three-cable --config-out /tmp/rig.toml
    python -m lab capture --rig hardware:/tmp/rig.toml ...      # in another shell

The body is a ``KinematicBody`` (tip linear in the motor angles); the servos and the
NatNet server are the same emulators the tests use.
"""

from __future__ import annotations

import argparse
import signal
import threading

from lab.description import load_robot
from lab.rig.emulators.bench import EmulatedBench


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m lab.rig.emulators", description=__doc__.splitlines()[0])
    ap.add_argument("--robot", default="three-cable", help="robot description name or TOML path")
    ap.add_argument("--config-out", required=True, help="where to write the hardware rig TOML")
    ap.add_argument("--multicast", action="store_true", help="stream multicast on loopback instead of unicast")
    ap.add_argument("--noise-mm", type=float, default=0.0, help="Gaussian marker noise, mm")
    args = ap.parse_args(argv)
    robot = load_robot(args.robot)
    with EmulatedBench(robot, multicast=args.multicast, noise_m=args.noise_mm * 1e-3) as bench:
        path = bench.write_config(args.config_out)
        print(
            f"servos on {bench.bus.port}, NatNet on 127.0.0.1:{bench.mocap.command_port}; "
            f"config written to {path}. Ctrl-C or SIGTERM stops.",
            flush=True,
        )
        stop = threading.Event()
        signal.signal(signal.SIGTERM, lambda *_: stop.set())
        try:
            while not stop.wait(0.5):
                pass
        except KeyboardInterrupt:
            pass
    m = bench.mocap
    behind = f"; {m.frames_skipped} frame times skipped: the machine fell behind" if m.frames_skipped else ""
    print(
        f"emulators stopped: {m.frames_sent} frames sent at {m.frame_rate_hz:g} Hz, the longest gap "
        f"{m.max_frame_gap_s:.3f} s{behind}",
        flush=True,
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
