"""HardwareRig end to end: real SDK + real NatNet client against the emulated bench.

The bench runs on its virtual clock (the same run on an idle or a loaded machine) except in
the multicast test, which streams on the wall clock at 120 Hz as Motive does."""

import copy
import json
import tomllib
from pathlib import Path

import numpy as np
import pytest
from helpers import wait_on_rig, wait_until

from lab.rig import make_rig
from lab.rig.base import MocapError, RigError, ServoError
from lab.rig.dynamixel import RAD_PER_TICK
from lab.rig.emulators import EmulatedBench
from lab.rig.hardware import HardwareRig
from lab.rig.hardware_config import HardwareConfigError, load_hardware_config, parse_hardware_config

EXAMPLE = Path(__file__).parents[1] / "lab" / "rigs" / "hardware-example.toml"


@pytest.fixture
def bench(three_cable):
    with EmulatedBench(three_cable, virtual_time=True) as b:
        yield b


def open_rig(bench, robot, path, **overrides) -> HardwareRig:
    return HardwareRig.from_config(bench.write_config(path, **overrides), robot, **bench.rig_options())


@pytest.fixture
def rig(bench, three_cable, tmp_path):
    r = open_rig(bench, three_cable, tmp_path / "rig.toml")
    yield r
    r.close()


def torque(bench):
    return [bench.bus.state(s.dxl_id)["torque_enable"] for s in bench.specs]


def settle(rig, u, tol_rad=2 * RAD_PER_TICK):
    """Frames of the settled tip: the servos reach ``u``, the body's motors follow at the
    same speed a little later; frames queued meanwhile are older and skipped by time stamp."""
    wait_on_rig(rig, lambda: np.allclose(rig.present_u(), u, atol=tol_rad), 5, "servos at goal")
    t_s = rig.now()
    return [f for f in rig.wait(0.6) if f.t_s > t_s + 0.35]


# --- configuration --------------------------------------------------------------------------
def test_example_config_is_valid(three_cable):
    c = load_hardware_config(EXAMPLE, three_cable)
    assert [s.cable for s in c.servos] == [cab.name for cab in three_cable.cables]
    assert (c.baud_rate, c.natnet.multicast, c.natnet.tip.marker, len(c.natnet.base_markers)) == (57600, True, "tip", 3)


def _motor(i, **kv):
    return lambda d: d["servos"]["motor"][i].update(kv)


@pytest.mark.parametrize(
    "mutate, field",
    [
        (lambda d: d.update(format_version=2), "format_version"),
        (lambda d: d["servos"].update(baud_rate=12345), "servos.baud_rate"),
        (lambda d: d["servos"].pop("port"), "servos.port"),
        (lambda d: d["servos"].update(profile_velocity_rad_s=-1.0), "servos.profile_velocity_rad_s"),
        (_motor(1, direction=0), "servos.motor[1].direction"),
        (_motor(0, cable="left"), "servos.motor[0].cable"),
        (_motor(2, id=300), "servos.motor[2].id"),
        (_motor(2, id=1), "servos.motor[].id must be distinct"),
        (_motor(1, zero_offset_ticks=1.5), "servos.motor[1].zero_offset_ticks"),
        (lambda d: d["servos"]["motor"].pop(), "has 2 entries but robot 'three-cable' has 3 cables"),
        (lambda d: d["mocap"].update(transmission="broadcast"), "mocap.transmission"),
        (lambda d: d["mocap"].update(server_address="motive.local"), "mocap.server_address"),
        (lambda d: d["mocap"].update(command_port=70000), "mocap.command_port"),
        (lambda d: d["mocap"].update(length_unit="cm"), "mocap.length_unit"),
        (lambda d: d["mocap"].update(frame_timeout_s=0), "mocap.frame_timeout_s"),
        (lambda d: d["mocap"]["tip"].update(rigid_body="tip"), "mocap.tip"),
        (lambda d: d["mocap"].pop("marker_set"), "mocap.tip.marker' needs a marker set"),
        (lambda d: d["mocap"]["base_markers"].pop(), "at least 3 markers"),
        (lambda d: d["mocap"]["base_markers"][1].update(position_W_m=[0, 0]), "mocap.base_markers[1].position_W_m"),
        (
            lambda d: [b.update(position_W_m=[0.0, 0.01 * i, 0.0]) for i, b in enumerate(d["mocap"]["base_markers"])],
            "collinear",
        ),
    ],
)
def test_bad_config_names_the_field(three_cable, mutate, field):
    data = tomllib.loads(EXAMPLE.read_text())
    mutate(data)
    with pytest.raises(HardwareConfigError, match=field.replace("[", r"\[").replace("]", r"\]").replace(".", r"\.")):
        parse_hardware_config(copy.deepcopy(data), three_cable)


def test_make_rig_hardware_needs_a_file(three_cable, tmp_path):
    with pytest.raises(ValueError, match="needs a configuration file"):
        make_rig("hardware", three_cable)
    with pytest.raises(HardwareConfigError, match="not found"):
        make_rig(f"hardware:{tmp_path / 'none.toml'}", three_cable)


def test_make_rig_hardware_opens_the_rig(three_cable, tmp_path):
    with EmulatedBench(three_cable) as bench:  # the wall clock: make_rig gives no other
        with make_rig(f"hardware:{bench.write_config(tmp_path / 'rig.toml')}", three_cable) as rig:
            assert isinstance(rig, HardwareRig) and np.allclose(rig.present_u(), 0.0, atol=1e-3)


# --- running -----------------------------------------------------------------------------------
def test_rig_moves_the_body_and_reads_its_tip_in_W(rig, bench):
    body = bench.body
    p_rest = rig.wait(0.2)[-1].p_tip_W
    assert np.allclose(p_rest, body.p_rest_W, atol=1e-6)
    u = np.array([1.2, 0.4, 0.0])
    rig.send(u)
    frames = settle(rig, u)
    assert np.allclose(body.u_goal_rad, u, atol=RAD_PER_TICK)  # signs and zeros right at the spools
    p_expected = body.p_rest_W + body.J_W @ u
    assert np.allclose(frames[-1].p_tip_W, p_expected, atol=5e-5)  # tip in W through NatNet
    assert np.linalg.norm(frames[-1].p_tip_W - p_rest) > 0.01
    t = [f.t_s for f in frames]
    assert 0 < t[0] <= t[-1] <= rig.now()
    info = json.loads(json.dumps(rig.describe(), allow_nan=False))
    assert info["kind"] == "hardware" and info["servo_models"] == ["XM430-W350"] * 3
    assert info["zero_ticks"] == [1000, 904, 3100] and info["base_fit_rms_m"] < 1e-6


def test_rig_on_natnet_4_1_multicast_in_millimetres_with_noise(three_cable, tmp_path):
    """On the wall clock, frames streamed at 120 Hz as Motive does. With two CPU-bound
    processes beside it on 2 cores the server's longest gap between frames was 0.07 s (0.01 s
    idle), so the frame timeout is 2 s; the servos' 0.5 s move has 5 s of rig time."""
    import dataclasses

    from lab.rig.emulators import MocapScene
    from lab.rig.emulators.natnet_server import multicast_loopback_works

    multicast = multicast_loopback_works()  # unicast where the machine cannot
    scene = dataclasses.replace(MocapScene(), length_unit_m=1e-3)
    with EmulatedBench(three_cable, scene=scene, natnet_version=(4, 1), multicast=multicast, noise_m=0.2e-3) as bench:
        cfg = bench.write_config(tmp_path / "rig.toml", mocap={"calibration_frames": 60, "frame_timeout_s": 2.0})
        with HardwareRig.from_config(cfg, three_cable, **bench.rig_options()) as rig:
            u = np.array([0.0, 1.0, 1.5])
            rig.send(u)
            frames = settle(rig, u)
            p = np.mean([f.p_tip_W for f in frames], axis=0)
            assert np.linalg.norm(p - (bench.body.p_rest_W + bench.body.J_W @ u)) < 1e-3
        print(f"max frame gap {bench.mocap.max_frame_gap_s:.3f} s, max bus gap {bench.bus.max_packet_gap_s:.3f} s")


def test_unsafe_command_is_refused_and_nothing_moves(rig, bench, three_cable):
    with pytest.raises(ValueError, match="violates the safety rule"):
        rig.send([three_cable.u_max_rad] * 3)
    rig.present_u()
    assert np.allclose(bench.body.u_goal_rad, 0.0) and torque(bench) == [1, 1, 1]


def test_servo_fault_on_send_stops_the_rig_with_torque_off(rig, bench):
    rig.send([0.5, 0.5, 0.5])
    settle(rig, [0.5, 0.5, 0.5])
    bench.bus.inject_fault(3, "overload")
    with pytest.raises(ServoError, match=r"servo ID 3 \(cable 'lower-right'\).*overload.*torque is off"):
        rig.send([0.6, 0.5, 0.5])
    assert torque(bench) == [0, 0, 0]
    wait_until(lambda: np.allclose(bench.body.u_goal_rad, 0.0), what="body released")
    assert "overload" in rig.failure
    with pytest.raises(RigError, match="closed"):
        rig.send([0.0, 0.0, 0.0])


def test_servo_fault_is_caught_while_only_frames_are_read(rig, bench):
    bench.bus.inject_fault(1, "silent")
    with pytest.raises(ServoError, match=r"servo ID 1 \(cable 'top'\).*no status packet"):
        rig.wait(2.0)
    assert torque(bench) == [0, 0, 0]  # the silent servo still obeys the broadcast torque off


def test_a_lost_status_packet_is_asked_for_again(rig, bench):
    """A reply lost to the timeout (a busy adapter, a loaded host) is not a failed servo: the
    sync read is sent again, up to READ_TRIES times; only then does the rig stop."""
    from lab.rig.dynamixel_units import READ_TRIES

    rig.send([0.2, 0.1, 0.0])
    bench.bus.inject_fault(1, "silent", count=READ_TRIES - 1)
    assert np.all(np.isfinite(rig.present_u())) and torque(bench) == [1, 1, 1]
    bench.bus.inject_fault(1, "silent", count=READ_TRIES)
    with pytest.raises(ServoError, match=r"servo ID 1 \(cable 'top'\).*no status packet"):
        rig.present_u()
    assert torque(bench) == [0, 0, 0]


def test_mocap_loss_stops_the_rig_with_torque_off(bench, three_cable, tmp_path):
    rig = open_rig(bench, three_cable, tmp_path / "rig.toml", mocap={"frame_timeout_s": 0.5})
    rig.send([0.5, 0.0, 0.0])
    bench.mocap.freeze()
    with pytest.raises(MocapError, match=r"no motion-capture frame.*\[hardware rig stopped: torque off\]"):
        rig.wait(3.0)
    assert torque(bench) == [0, 0, 0]


def test_long_occlusion_stops_the_rig_with_torque_off(rig, bench):
    bench.mocap.occlude_tip(True)
    with pytest.raises(MocapError, match=r"occluded for 0\.5\d s.*torque off"):
        rig.wait(3.0)
    assert torque(bench) == [0, 0, 0]


def test_failed_start_leaves_torque_off(bench, three_cable, tmp_path):
    with pytest.raises(MocapError, match="no marker set 'nope'"):
        open_rig(bench, three_cable, tmp_path / "bad-mocap.toml", mocap={"marker_set": "nope"})
    with pytest.raises(ServoError, match=r"servo ID 1 .*ping .* at 1000000 baud"):
        open_rig(
            bench, three_cable, tmp_path / "bad-servo.toml", servos={"baud_rate": 1000000, "latency_timer_ms": 20.0}
        )
    assert torque(bench) == [0, 0, 0]


def test_close_is_idempotent(rig, bench):
    rig.close()
    rig.close()
    assert torque(bench) == [0, 0, 0] and rig.torque_unconfirmed == []
    with pytest.raises(RigError, match="closed"):
        rig.present_u()


@pytest.mark.slow
def test_rig_drives_the_emulated_as_built_robot(three_cable, tmp_path):
    """The whole hardware path against the twin's AsBuiltBody (coarse FEM): foam lag and
    cable play included, the tip read through NatNet is the body's true tip."""
    from lab.rig.twin import AsBuiltBody

    body = AsBuiltBody(three_cable, n_rings=2, n_axial=8)
    with EmulatedBench(three_cable, body, virtual_time=True) as bench:
        with open_rig(bench, three_cable, tmp_path / "rig.toml") as rig:
            p_rest = rig.wait(0.2)[-1].p_tip_W
            u = np.array([1.5, 0.0, 0.0])
            rig.send(u)
            wait_on_rig(rig, lambda: np.allclose(rig.present_u(), u, atol=2 * RAD_PER_TICK), 5, "servos at goal")
            rig.wait(2.0)
            last = rig.wait(0.1)[-1]
            p_true = bench.live.state()[1]  # at the last frame's time: the clock waits for the next wish
            assert np.linalg.norm(last.p_tip_W - p_true) < 1e-6  # NatNet sends float32
            assert np.linalg.norm(last.p_tip_W - p_rest) > 0.02
            assert body.profile_velocity_rad_s == pytest.approx(3.0, abs=0.01)
        assert bench.bus.body_error is None
