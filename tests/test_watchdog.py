"""The XM430 Bus Watchdog: servos whose host died stop by themselves.

The emulated servo implements the watchdog as the e-Manual describes it (address 98,
20 ms units; fired: stops, reads -1, goals and profile locked until cleared); the driver
arms it after torque on, re-arms it after a quiet bus (resuming a move it stopped) and
clears a fired one on connecting; a ``track`` process killed with ``kill -9`` on the
emulated hardware leaves servos that stop within the watchdog time. All but the last run
on the bench's virtual clock (``docs/design/hardware-tests.md``).
"""

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from helpers import subprocess_env, wait_on_rig, wait_until

from lab.control import circle
from lab.control.trajectories import write_trajectory_csv
from lab.rig.emulators import EmulatedBench
from lab.rig.emulators import protocol2 as p2
from lab.rig.emulators.xm430_servo import ADDR, EmulatedServo, ServoSpec
from lab.rig.hardware import HardwareRig


def _servo(t=0.0):
    s = EmulatedServo(ServoSpec(dxl_id=1), t)
    s.write(ADDR["operating_mode"], b"\x04", t)  # extended position mode, as the driver sets it
    s.write(ADDR["profile_velocity"], (20).to_bytes(4, "little"), t)  # slow: 0.48 rad/s
    s.write(ADDR["torque_enable"], b"\x01", t)
    return s


def test_emulated_servo_stops_when_the_watchdog_fires():
    s = _servo()
    start = s.get("present_position")
    s.write(ADDR["bus_watchdog"], b"\x05", 0.0)  # 100 ms
    s.heard(0.0)
    assert s.write(ADDR["goal_position"], (start + 4000).to_bytes(4, "little"), 0.0) == 0
    s.advance(0.05)
    assert s.get("bus_watchdog") == 5 and s.get("moving") == 1
    s.advance(0.5)  # nothing heard since t = 0: fired at 0.1 s
    stopped = s.get("present_position")
    assert s.get("bus_watchdog") == 0xFF and s.get("goal_position") == stopped
    moved_by_trip = (stopped - start) / 4096 * 2 * np.pi
    assert 0.04 < moved_by_trip < 0.06  # 0.48 rad/s for 0.1 s
    s.advance(2.0)
    assert s.get("present_position") == stopped and s.get("moving") == 0
    # goals are locked until the watchdog is cleared
    s.heard(2.0)
    assert s.write(ADDR["goal_position"], (start + 4000).to_bytes(4, "little"), 2.0) & 0x7F == p2.ERR_DATA_RANGE
    assert s.write(ADDR["bus_watchdog"], b"\x00", 2.0) == 0
    assert s.write(ADDR["goal_position"], (start + 4000).to_bytes(4, "little"), 2.0) == 0


def test_emulated_servo_keeps_going_while_it_hears_packets():
    s = _servo()
    s.write(ADDR["bus_watchdog"], b"\x05", 0.0)
    for k in range(1, 20):
        s.heard(0.08 * k)  # every 80 ms < 100 ms
    assert s.get("bus_watchdog") == 5
    assert s.write(ADDR["bus_watchdog"], bytes([200]), 2.0) & 0x7F == p2.ERR_DATA_RANGE  # 128..254 are invalid


def test_driver_arms_and_rearms_the_watchdog(three_cable, tmp_path):
    with EmulatedBench(three_cable, virtual_time=True) as bench:
        cfg = bench.write_config(tmp_path / "rig.toml", servos={"bus_watchdog_ms": 100})
        with HardwareRig.from_config(cfg, three_cable, **bench.rig_options()) as rig:
            assert [bench.bus.servo(s.dxl_id).get("bus_watchdog") for s in bench.specs] == [5, 5, 5]
            bench.clock.advance(0.4)  # a quiet bus: every watchdog fires
            for spec in bench.specs:
                bench.bus.state(spec.dxl_id)  # advance the emulated servo to now
            assert all(bench.bus.servo(spec.dxl_id).watchdog_tripped for spec in bench.specs)
            u = np.array([0.3, 0.2, 0.1])
            rig.send(u)  # re-armed before the goals are written: the arm moves again
            wait_on_rig(rig, lambda: np.allclose(rig.present_u(), u, atol=0.01), 10, "servos at the new goal")
            assert [bench.bus.servo(s.dxl_id).get("bus_watchdog") for s in bench.specs] == [5, 5, 5]


def test_a_stall_mid_move_stops_the_servos_and_the_driver_resumes(three_cable, tmp_path):
    """The host stalls longer than the watchdog while the spools turn: they stop where they
    are; the driver's next exchange re-arms the watchdog and writes the goal again."""
    with EmulatedBench(three_cable, virtual_time=True) as bench:
        ids = [s.dxl_id for s in bench.specs]
        cfg = bench.write_config(tmp_path / "rig.toml", servos={"bus_watchdog_ms": 100, "profile_velocity_rad_s": 1.0})
        with HardwareRig.from_config(cfg, three_cable, **bench.rig_options()) as rig:
            u = np.array([1.0, 0.5, 0.0])
            rig.send(u)
            rig.wait(0.2)  # 0.2 rad on the way
            bench.clock.advance(0.5)  # the host stalls
            stopped = [bench.bus.state(i)["present_position"] for i in ids]
            assert all(bench.bus.servo(i).watchdog_tripped for i in ids)
            u_stopped = rig.present_u()  # the driver re-arms and writes the goal again ...
            assert 0.2 < u_stopped[0] < 0.4 and [bench.bus.state(i)["present_position"] for i in ids] == stopped
            wait_on_rig(rig, lambda: np.allclose(rig.present_u(), u, atol=0.01), 10, "servos at the goal")
            assert [bench.bus.servo(i).get("bus_watchdog") for i in ids] == [5, 5, 5]  # ... and they go on


def test_a_new_session_clears_a_fired_watchdog_and_moves(three_cable, tmp_path):
    """A session dies without a word (kill -9): its servos' watchdog fires and locks goals and
    profile. The next session clears it before writing the profile velocity, and moves."""
    from lab.rig.dynamixel import XM430Bus
    from lab.rig.hardware_config import load_hardware_config

    with EmulatedBench(three_cable, virtual_time=True) as bench:
        cfg = bench.write_config(tmp_path / "rig.toml", servos={"bus_watchdog_ms": 100})
        c = load_hardware_config(cfg, three_cable)
        first = XM430Bus(
            c.port,
            c.baud_rate,
            c.servos,
            profile_velocity_rad_s=3.0,
            bus_watchdog_ms=100,
            latency_timer_ms=c.latency_timer_ms,
            clock=bench.clock,
            reply_timer=time.thread_time,
        )
        first.torque_on()
        first.write_goal_u([0.5, 0.5, 0.5])  # ... and then nothing more: no close, no torque off
        ids = [s.dxl_id for s in bench.specs]
        bench.clock.advance(1.0)
        assert [bench.bus.state(i)["torque_enable"] for i in ids] == [1, 1, 1]
        assert all(bench.bus.servo(i).watchdog_tripped for i in ids)
        with HardwareRig.from_config(cfg, three_cable, **bench.rig_options()) as rig:
            u = np.array([0.2, 0.6, 0.4])
            rig.send(u)
            wait_on_rig(rig, lambda: np.allclose(rig.present_u(), u, atol=0.01), 10, "servos at the goal")
        assert [bench.bus.state(i)["torque_enable"] for i in ids] == [0, 0, 0]


def test_config_watchdog_field(three_cable, tmp_path):
    from lab.rig.hardware_config import HardwareConfigError, load_hardware_config

    with EmulatedBench(three_cable) as bench:
        assert load_hardware_config(bench.write_config(tmp_path / "a.toml"), three_cable).bus_watchdog_ms == 500
        with pytest.raises(HardwareConfigError, match="bus_watchdog_ms"):
            load_hardware_config(bench.write_config(tmp_path / "b.toml", servos={"bus_watchdog_ms": 5}), three_cable)


#: The real-time test's margins (its docstring derives them).
WATCHDOG_MS = 500
FRAME_TIMEOUT_S = 2.0
FIRST_POINT_TIMEOUT_S = 120.0


@pytest.mark.parametrize("how", ["kill-9", "sigterm"])
def test_killed_track_process_leaves_the_servos_stopped(how, three_cable, tmp_path):
    """A `track` on the emulated hardware killed mid-trajectory: with SIGTERM the rig closes
    (torque off, exit 143); with kill -9 nothing runs, the Bus Watchdog stops the servos, and
    the next session clears the fired watchdog and moves.

    On the wall clock, as it must be with a second process. Margins, measured with two
    CPU-bound processes beside it on 2 cores (load 3-6; printed below): the bench's server,
    in this process, sent a frame at least every 0.04 s (0.01 s idle), so ``FRAME_TIMEOUT_S``
    is 2 s; `track` fed the bus at least every 0.11 s, under half the 500 ms watchdog (the
    driver re-arms it after any longer spell, and resumes a move it stopped). The emulated bus
    is a thread of this loaded process: once it answered a sync read later than the driver's
    0.2 s reply timeout, so the driver asks again (``READ_TRIES``). The first point
    comes after ~8 s idle (start-up and IK), ~15 s loaded: ``FIRST_POINT_TIMEOUT_S`` is 120 s,
    and a `track` that exits first fails the test at once with its stderr. After the kill the
    emulated servos stop where they were when the watchdog time had passed since the last
    packet, whenever the check runs, so it only needs to wait past that time.
    """
    write_trajectory_csv(tmp_path / "traj.csv", circle(200))
    model = os.path.join(os.path.dirname(__file__), "..", "data", "model_sim_three_cable.npz")
    with EmulatedBench(three_cable) as bench:
        cfg = bench.write_config(
            tmp_path / "rig.toml",
            servos={"bus_watchdog_ms": WATCHDOG_MS, "profile_velocity_rad_s": 0.5},
            mocap={"frame_timeout_s": FRAME_TIMEOUT_S},
        )
        stderr = tmp_path / "stderr.txt"
        with open(stderr, "w") as err_file:
            proc = subprocess.Popen(
                [
                    sys.executable,
                    "-m",
                    "lab",
                    "track",
                    "--model",
                    model,
                    "--trajectory",
                    str(tmp_path / "traj.csv"),
                    "--rig",
                    f"hardware:{cfg}",
                    "--out",
                    str(tmp_path / "r.json"),
                ],
                cwd=tmp_path,
                env=subprocess_env(),
                stderr=err_file,
                text=True,
            )
        try:
            points = tmp_path / "r.json.points.csv"

            def n_points():
                if proc.poll() is not None:
                    raise AssertionError(f"track exited ({proc.returncode}) early:\n{stderr.read_text()[-3000:]}")
                return points.exists() and len(points.read_text().splitlines()) - 1

            wait_until(lambda: n_points() >= 1, FIRST_POINT_TIMEOUT_S, "a measured point")
            bench.bus.max_packet_gap_s = bench.mocap.max_frame_gap_s = 0.0
            wait_until(lambda: n_points() >= 3, FIRST_POINT_TIMEOUT_S, "three measured points")
            print(f"max bus gap {bench.bus.max_packet_gap_s:.3f} s, max frame gap {bench.mocap.max_frame_gap_s:.3f} s")
            ids = [s.dxl_id for s in bench.specs]
            if how == "kill-9":
                proc.kill()
                proc.wait()
                t_kill = time.monotonic()
                time.sleep(WATCHDOG_MS / 1000 + 0.1)  # the servos last heard a packet before the kill
                before = [bench.bus.state(i)["present_position"] for i in ids]
                time.sleep(0.5)
                after = [bench.bus.state(i)["present_position"] for i in ids]
                assert before == after, "servos still moving after the watchdog time"
                assert all(bench.bus.servo(i).watchdog_tripped for i in ids)
                assert time.monotonic() - t_kill < 5
                with HardwareRig.from_config(cfg, three_cable, **bench.rig_options()) as rig:  # the next session
                    u = np.array([0.3, 0.2, 0.1])
                    rig.send(u)
                    wait_until(lambda: np.allclose(rig.present_u(), u, atol=0.01), 60, "servos at the new goal")
            else:
                proc.send_signal(signal.SIGTERM)
                proc.communicate(timeout=60)
                err = stderr.read_text()
                assert proc.returncode == 143, err
                assert "interrupted by SIGTERM" in err and "points measured so far" in err
                assert [bench.bus.state(i)["torque_enable"] for i in ids] == [0, 0, 0]
        finally:
            if proc.poll() is None:
                proc.kill()
