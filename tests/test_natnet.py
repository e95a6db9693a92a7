"""OptiTrackStream on the real natnet client against the NatNet server emulator (loopback)."""

import dataclasses
import socket
import time

import numpy as np
import pytest
from natnet import DataDescriptions, DataFrame, ServerInfo, Version
from natnet.packet_buffer import PacketBuffer

from lab.rig.base import MocapError
from lab.rig.emulators import MocapScene, NatNetServerEmulator, VirtualClock
from lab.rig.emulators import natnet_packets as nn
from lab.rig.emulators.natnet_server import multicast_loopback_works
from lab.rig.optitrack import MarkerRef, NatNetConfig, OptiTrackStream, fit_rigid_transform

SCENE = MocapScene()
TIP_W = np.array([0.19, 0.012, -0.021])


def fixed_tip(_t):
    return TIP_W


def config(server, tip=MarkerRef(marker="tip", marker_set="soft_arm"), scene=SCENE, **kw):
    bases = tuple(MarkerRef(marker=n, marker_set=scene.marker_set) for n in scene.base_markers)
    return NatNetConfig(
        "127.0.0.1",
        "127.0.0.1",
        server.multicast,
        tip,
        bases,
        np.array(scene.base_positions_W_m),
        command_port=server.command_port,
        data_port=server.data_port,
        multicast_address=server.multicast_address,
        length_unit_m=scene.length_unit_m,
        **({"calibration_frames": 12, "connect_timeout_s": 3.0, "frame_timeout_s": 1.0} | kw),
    )


class Lab:
    """Servers and streams made by a test; streams close before servers stop."""

    def __init__(self):
        self.servers, self.streams = [], []

    def server(self, tip=fixed_tip, scene=SCENE, **kw):
        srv = NatNetServerEmulator(tip, scene, **kw).start()
        self.servers.append(srv)
        return srv

    def stream(self, cfg, **kw):
        s = OptiTrackStream(cfg, **kw)
        self.streams.append(s)
        return s

    def close(self):
        for s in self.streams:
            s.close()
        for srv in self.servers:
            srv.stop()


@pytest.fixture
def lab():
    lab = Lab()
    yield lab
    lab.close()


# --- geometry and packets ----------------------------------------------------------------
def test_kabsch_recovers_a_rigid_transform():
    rng = np.random.default_rng(3)
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    R = q * np.sign(np.linalg.det(q))  # a proper rotation
    t = rng.normal(size=3)
    p = rng.normal(size=(4, 3))
    R_fit, t_fit, rms = fit_rigid_transform(p, p @ R.T + t)
    assert np.allclose(R_fit, R) and np.allclose(t_fit, t) and rms < 1e-12
    mirrored = p * [1, 1, -1]  # no rotation maps p onto its mirror image
    R_m, _, rms_m = fit_rigid_transform(p, mirrored)
    assert np.linalg.det(R_m) == pytest.approx(1.0) and rms_m > 0.1


@pytest.mark.parametrize("version", nn.SUPPORTED_VERSIONS)
def test_emulator_packets_parse_with_the_real_client(version):
    V = Version(*version, 0, 0)
    frame = nn.Frame(
        42,
        3.5,
        marker_sets=[("soft_arm", [(1.0, 2.0, 3.0), (0.0, 0.0, 0.0)])],
        unlabeled=[(7.0, 8.0, 9.0)],
        rigid_bodies=[nn.RigidBodyState(7, (0.5, 0.25, 0.125))],
        labeled=[nn.LabeledMarkerState(65537, (1.0, 2.0, 3.0), param=nn.MARKER_OCCLUDED)],
    )
    buf = PacketBuffer(nn.frame_of_data(version, frame))
    assert buf.read_uint16() == nn.NAT_FRAMEOFDATA and buf.read_uint16() == len(buf.data) - 4
    df = DataFrame.read_from_buffer(buf, V)
    assert df.prefix.frame_number == 42 and df.suffix.timestamp == 3.5
    assert df.marker_sets[0].model_name == "soft_arm" and df.marker_sets[0].marker_pos_list[0] == (1.0, 2.0, 3.0)
    assert df.unlabeled_marker_pos == ((7.0, 8.0, 9.0),)
    assert df.rigid_bodies[0].id_num == 7 and df.rigid_bodies[0].pos == (0.5, 0.25, 0.125)
    assert df.rigid_bodies[0].tracking_valid is True
    assert df.labeled_markers[0].occluded and df.labeled_markers[0].model_id == 1
    buf = PacketBuffer(
        nn.model_def(version, [("soft_arm", ["tip", "base_1"])], [("tip_body", 7, -1, (0, 0, 0), [(0.01, 0, 0)])])
    )
    buf.read_uint16(), buf.read_uint16()
    dd = DataDescriptions.read_from_buffer(buf, V)
    assert dd.marker_sets[0].marker_names == ("tip", "base_1") and dd.rigid_bodies[0].name == "tip_body"
    assert buf.pointer == len(buf.data)
    buf = PacketBuffer(nn.server_info(version))
    buf.read_uint16(), buf.read_uint16()
    assert ServerInfo.read_from_buffer(buf, None).nat_net_protocol_version == V


# --- streaming ---------------------------------------------------------------------------
@pytest.mark.parametrize("version", [(3, 1), (4, 1)])
def test_unicast_stream_gives_the_tip_in_W(lab, version):
    srv = lab.server(version=version)
    s = lab.stream(config(srv))
    assert s.base_fit_rms_m < 1e-6
    assert np.allclose(s.R_WM, SCENE.R_MW.T, atol=1e-6)
    frames = [s.next_frame() for _ in range(60)]
    assert all(f.valid for f in frames)
    assert np.max(np.abs(np.array([f.p_tip_W for f in frames]) - TIP_W)) < 1e-6  # float32 on the wire
    t = np.array([f.t_s for f in frames])
    assert np.all(np.diff(t) >= 0)
    print(f"NatNet {version}: {s.measured_rate_hz:.1f} Hz received (server 120 Hz)")
    assert 40 < s.measured_rate_hz < 200


def test_multicast_stream(lab):
    if not multicast_loopback_works():
        pytest.skip("this machine does not deliver multicast on loopback")
    srv = lab.server(multicast=True)
    s = lab.stream(config(srv))
    assert np.allclose(s.next_frame().p_tip_W, TIP_W, atol=1e-6)


@pytest.mark.parametrize(
    "tip",
    [MarkerRef(labeled_marker_id=(1 << 16) | 1), MarkerRef(rigid_body="tip_body"), MarkerRef(rigid_body_id=7)],
    ids=str,
)
def test_other_ways_to_name_the_tip(lab, tip):
    srv = lab.server()
    s = lab.stream(config(srv, tip=tip))
    assert np.allclose(s.next_frame().p_tip_W, TIP_W, atol=1e-6)


def test_millimetres_and_noise(lab):
    scene = dataclasses.replace(SCENE, length_unit_m=1e-3)
    srv = lab.server(scene=scene, noise_m=0.3e-3, seed=1)
    s = lab.stream(config(srv, scene=scene, calibration_frames=60))
    p = np.array([s.next_frame().p_tip_W for _ in range(60)])
    # Base-marker noise left in frame W is magnified ~5x at the tip (lever 20 cm over a
    # base ~7 cm wide): 0.3 mm / sqrt(60) * 5 ~ 0.2 mm per axis; allow about 3 sigma.
    assert np.linalg.norm(p.mean(axis=0) - TIP_W) < 1.0e-3
    assert 0.15e-3 < p.std(axis=0).mean() < 0.5e-3


def test_moving_tip_is_followed(lab):
    srv = lab.server(tip=lambda t: TIP_W + [0.0, 0.05 * np.sin(8 * np.pi * t), 0.0])  # 4 Hz
    s = lab.stream(config(srv))
    y = np.array([s.next_frame().p_tip_W[1] for _ in range(45)])  # 1.5 periods
    assert y.max() - y.min() > 0.04


# --- faults --------------------------------------------------------------------------------
def test_occlusion_gives_nan_frames_then_an_error(lab):
    """On a virtual clock (a frame period per frame read), so the occlusion's length when it
    is refused is the limit plus one frame, whatever the machine's load."""
    clock = VirtualClock()
    srv = lab.server(clock=clock)
    s = lab.stream(config(srv, max_occlusion_s=0.4), clock=clock, frame_wanted=clock.want_frame)
    assert s.next_frame().valid
    srv.occlude_tip(True)
    frame = s.next_frame()
    assert not frame.valid and np.all(np.isnan(frame.p_tip_W))
    for _ in range(24):  # 0.2 s
        assert not s.next_frame().valid
    srv.occlude_tip(False)  # back before the limit: no error
    assert s.next_frame().valid
    srv.occlude_tip(True)
    t0 = clock.now()
    with pytest.raises(MocapError, match=r"tip marker 'tip' of marker set 'soft_arm' occluded for 0\.41 s"):
        while True:
            assert np.all(np.isnan(s.next_frame().p_tip_W))
    assert clock.now() - t0 == pytest.approx(0.4 + 1 / 120, abs=1e-9)


def test_server_that_disappears(lab):
    srv = lab.server()
    s = lab.stream(config(srv, frame_timeout_s=1.0))  # 14x the longest gap between frames under load
    s.next_frame()
    srv.freeze()
    t0 = time.monotonic()
    with pytest.raises(
        MocapError, match=r"no motion-capture frame from NatNet server 127\.0\.0\.1:\d+ \(unicast\) for 1\.0 s"
    ):
        while True:
            s.next_frame()
    assert time.monotonic() - t0 < 3.0


@pytest.mark.filterwarnings("ignore::pytest.PytestUnhandledThreadExceptionWarning")
def test_server_closed_under_the_client(lab):
    """The client's keepalives then meet ICMP port-unreachable, which ends natnet's own
    receive thread; the stream reports the silence."""
    srv = lab.server()
    s = lab.stream(config(srv, frame_timeout_s=1.0))  # 14x the longest gap between frames under load
    srv.stop()
    with pytest.raises(MocapError, match="no motion-capture frame"):
        while True:
            s.next_frame()


def test_no_server(lab):
    srv = lab.server()
    cfg = dataclasses.replace(config(srv), command_port=_unused_port(), connect_timeout_s=0.5)
    with pytest.raises(MocapError, match=r"cannot connect to NatNet server 127\.0\.0\.1:\d+ \(unicast\) within 0\.5 s"):
        lab.stream(cfg)


def _unused_port():
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.parametrize(
    "tip, message",
    [
        (MarkerRef(marker="nose", marker_set="soft_arm"), r"has no marker 'nose'; it has \['tip', 'base_1'"),
        (MarkerRef(marker="tip", marker_set="arm"), r"has no marker set 'arm'; it has \['all', 'soft_arm'\]"),
        (MarkerRef(rigid_body="wand"), r"has no rigid body 'wand'; it has \['tip_body'\]"),
    ],
)
def test_unknown_names_list_what_exists(lab, tip, message):
    srv = lab.server()
    with pytest.raises(MocapError, match=message):
        lab.stream(config(srv, tip=tip))


def test_wrong_base_positions_are_refused(lab):
    srv = lab.server()
    cfg = config(srv)
    swapped = cfg.base_positions_W_m[[1, 0, 2]]  # two base markers mislabelled
    with pytest.raises(MocapError, match=r"fit RMS \d+\.\d mm > 3\.0 mm"):
        lab.stream(dataclasses.replace(cfg, base_positions_W_m=swapped))


def test_full_queue_drops_the_oldest_frames(lab):
    srv = lab.server()
    s = lab.stream(config(srv, queue_frames=5))
    deadline = time.monotonic() + 5.0
    while s.frames_dropped == 0:
        assert time.monotonic() < deadline, "no frame dropped"
        time.sleep(0.02)
    t_before = time.monotonic()
    first = s.next_frame()
    assert first.t_s > t_before - 0.5  # what is left is recent
