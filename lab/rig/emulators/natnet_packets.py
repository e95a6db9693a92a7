"""NatNet messages as a Motive server writes them (NatNet 3.0, 3.1, 4.0, 4.1).

Written from the NatNet packet layout, checked against what the ``natnet`` client
package (``natnet.DataFrame``/``DataDescriptions``/``ServerInfo``) parses. Every message
is ``uint16 message id, uint16 payload size, payload``, little-endian. Positions are
float32 in the mocap frame and unit; strings are NUL-terminated UTF-8.

From NatNet 4.1 on, every list in a frame of data and every data description carries
its size in bytes after its count/type; 4.1 also appends a precision timestamp to the
frame suffix (the ``natnet`` 0.3.0 client does not read it and so takes its first two
bytes as the frame parameters; harmless, as they are zero here).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field

from lab.errors import InputError

NAT_CONNECT, NAT_SERVERINFO, NAT_REQUEST, NAT_RESPONSE = 0, 1, 2, 3
NAT_REQUEST_MODELDEF, NAT_MODELDEF, NAT_REQUEST_FRAMEOFDATA, NAT_FRAMEOFDATA = 4, 5, 6, 7
NAT_MESSAGESTRING, NAT_DISCONNECT, NAT_KEEPALIVE, NAT_UNRECOGNIZED_REQUEST = 8, 9, 10, 100
SUPPORTED_VERSIONS = ((3, 0), (3, 1), (4, 0), (4, 1))

# labeled-marker parameter bits
MARKER_OCCLUDED, MARKER_PC_SOLVED, MARKER_MODEL_SOLVED = 0x01, 0x02, 0x04


def _s(text: str) -> bytes:
    return text.encode("utf-8") + b"\0"


def message(message_id: int, payload: bytes) -> bytes:
    return struct.pack("<HH", message_id, len(payload)) + payload


@dataclass(frozen=True)
class RigidBodyState:
    """A rigid body in one frame: ``id_num``, position (3,), quaternion (qx, qy, qz, qw)."""

    id_num: int
    pos: tuple
    quat: tuple = (0.0, 0.0, 0.0, 1.0)
    mean_error: float = 0.0
    tracking_valid: bool = True


@dataclass(frozen=True)
class LabeledMarkerState:
    """A labeled marker: ``id_num`` = (model id << 16) | marker index, position (3,)."""

    id_num: int
    pos: tuple
    size: float = 0.014
    param: int = MARKER_PC_SOLVED
    residual: float = 0.0002


@dataclass(frozen=True)
class Frame:
    """One frame of data; positions in the mocap frame and unit."""

    frame_number: int
    timestamp_s: float
    marker_sets: list = field(default_factory=list)  # [(name, [(x, y, z), ...])]
    unlabeled: list = field(default_factory=list)  # [(x, y, z)]
    rigid_bodies: list = field(default_factory=list)  # [RigidBodyState]
    labeled: list = field(default_factory=list)  # [LabeledMarkerState]
    stamp_ticks: int = 0  # high-resolution clock, ticks


def _check(version) -> tuple[int, int]:
    v = tuple(version)[:2]
    if v not in SUPPORTED_VERSIONS:
        raise InputError(f"NatNet version {version} not emulated; supported: {SUPPORTED_VERSIONS}")
    return v


def _list(version, count: int, body: bytes) -> bytes:
    """A counted list; from 4.1 on followed by its size in bytes."""
    head = struct.pack("<I", count)
    if version >= (4, 1):
        head += struct.pack("<I", len(body))
    return head + body


def server_info(
    version,
    *,
    app_name: str = "Motive",
    app_version=(2, 3, 7, 1),
    multicast: bool = False,
    multicast_address: str = "239.255.42.99",
    data_port: int = 1511,
    clock_hz: int = 10_000_000,
) -> bytes:
    """NAT_SERVERINFO: application name (256 bytes), versions, clock, connection info."""
    v = _check(version)
    name = app_name.encode("utf-8")[:255].ljust(256, b"\0")
    payload = name + bytes(app_version) + bytes((v[0], v[1], 0, 0))
    payload += struct.pack("<Q", clock_hz)
    payload += struct.pack("<BH", 1, data_port) + struct.pack("<B", int(multicast))
    payload += bytes(int(p) for p in multicast_address.split("."))
    return message(NAT_SERVERINFO, payload)


def model_def(version, marker_sets=(), rigid_bodies=()) -> bytes:
    """NAT_MODELDEF: marker sets ``[(name, [marker names])]`` and rigid bodies
    ``[(name, id, parent_id, offset (3,), [marker offsets (3,)])]``."""
    v = _check(version)
    items = []
    for name, names in marker_sets:
        items.append((0, _s(name) + struct.pack("<I", len(names)) + b"".join(_s(n) for n in names)))
    for name, id_num, parent, offset, markers in rigid_bodies:
        body = _s(name) + struct.pack("<ii3f", id_num, parent, *offset)
        body += struct.pack("<I", len(markers))
        body += b"".join(struct.pack("<3f", *m) for m in markers)
        body += b"".join(struct.pack("<i", k + 1) for k in range(len(markers)))  # active labels
        if v >= (4, 0):
            body += b"".join(_s(f"Marker{k + 1}") for k in range(len(markers)))
        items.append((1, body))
    payload = struct.pack("<I", len(items))
    for kind, body in items:
        payload += struct.pack("<I", kind)
        if v >= (4, 1):
            payload += struct.pack("<I", len(body))
        payload += body
    return message(NAT_MODELDEF, payload)


def frame_of_data(version, frame: Frame) -> bytes:
    """NAT_FRAMEOFDATA for ``frame``."""
    v = _check(version)
    out = struct.pack("<I", frame.frame_number)
    sets = b"".join(
        _s(name) + struct.pack("<I", len(ps)) + b"".join(struct.pack("<3f", *p) for p in ps)
        for name, ps in frame.marker_sets
    )
    out += _list(v, len(frame.marker_sets), sets)
    out += _list(v, len(frame.unlabeled), b"".join(struct.pack("<3f", *p) for p in frame.unlabeled))
    rbs = b"".join(
        struct.pack("<I3f4ffH", rb.id_num, *rb.pos, *rb.quat, rb.mean_error, int(rb.tracking_valid))
        for rb in frame.rigid_bodies
    )
    out += _list(v, len(frame.rigid_bodies), rbs)
    out += _list(v, 0, b"")  # skeletons
    if v >= (4, 1):
        out += _list(v, 0, b"")  # assets
    lms = b"".join(struct.pack("<I3ffHf", m.id_num, *m.pos, m.size, m.param, m.residual) for m in frame.labeled)
    out += _list(v, len(frame.labeled), lms)
    out += _list(v, 0, b"")  # force plates
    out += _list(v, 0, b"")  # devices
    out += struct.pack("<IId", 0, 0, frame.timestamp_s)  # timecode, subframe, timestamp
    out += struct.pack("<QQQ", frame.stamp_ticks, frame.stamp_ticks, frame.stamp_ticks)
    if v >= (4, 1):
        out += struct.pack("<II", 0, 0)  # precision timestamp s, fraction
    out += struct.pack("<H", 0)  # params: not recording
    out += struct.pack("<i", 0)  # end of data
    return message(NAT_FRAMEOFDATA, out)
