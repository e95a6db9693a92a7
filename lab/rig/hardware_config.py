"""The hardware rig's TOML configuration -> a validated ``HardwareConfig``.

See ``lab/rigs/hardware-example.toml`` for a documented file to copy and edit. Every
field is checked against its type and range, the motors against the robot description
(one ``[[servos.motor]]`` per cable, in the description's cable order, named by cable),
and a bad file raises ``HardwareConfigError`` naming the field.
"""

from __future__ import annotations

import ipaddress
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from lab.description import RobotDescription, check_fields, read_toml
from lab.errors import InputError
from lab.rig.dynamixel import SDK_BAUD_RATES, ServoConfig
from lab.rig.optitrack import MarkerRef, NatNetConfig

FORMAT_VERSION = 1
LENGTH_UNITS_M = {"m": 1.0, "mm": 1e-3}


class HardwareConfigError(InputError):
    """A hardware rig configuration file is missing a field or has an invalid value."""


@dataclass(frozen=True)
class HardwareConfig:
    """Servo bus and motion-capture settings (SI units)."""

    source: str
    port: str
    baud_rate: int
    servos: tuple
    profile_velocity_rad_s: float
    latency_timer_ms: float
    start_margin_rad: float
    poll_interval_s: float
    frame_rate_hz: float
    bus_watchdog_ms: float
    natnet: NatNetConfig


_MISSING = object()


def _field(table: dict, key: str, where: str, kind, default=_MISSING, *, positive=False, nonneg=False):
    name = f"{where}.{key}" if where else key
    if key not in table:
        if default is _MISSING:
            raise HardwareConfigError(f"missing field '{name}'")
        return default
    v = table[key]
    ok = {
        float: isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v),
        int: isinstance(v, int) and not isinstance(v, bool),
        str: isinstance(v, str) and v != "",
        bool: isinstance(v, bool),
    }[kind]
    if not ok:
        raise HardwareConfigError(
            f"field '{name}' must be a {'non-empty string' if kind is str else kind.__name__}"
            f"{' (finite)' if kind is float else ''}, got {v!r}"
        )
    if (positive and v <= 0) or (nonneg and v < 0):
        raise HardwareConfigError(f"field '{name}' must be {'positive' if positive else '>= 0'}, got {v!r}")
    return kind(v)


#: The fields of each table of a hardware config.
CONFIG_FIELDS = {
    "": {"format_version", "servos", "mocap"},
    "servos": {
        "port",
        "baud_rate",
        "profile_velocity_rad_s",
        "latency_timer_ms",
        "start_margin_rad",
        "poll_interval_s",
        "bus_watchdog_ms",
        "motor",
    },
    "servos.motor": {"cable", "id", "direction", "zero_offset_ticks"},
    "mocap": {
        "server_address",
        "local_address",
        "transmission",
        "multicast_address",
        "command_port",
        "data_port",
        "length_unit",
        "frame_rate_hz",
        "connect_timeout_s",
        "frame_timeout_s",
        "max_occlusion_s",
        "calibration_frames",
        "max_base_fit_rms_m",
        "queue_frames",
        "marker_set",
        "tip",
        "base_markers",
    },
    "mocap.tip": {"marker", "marker_set", "labeled_marker_id", "rigid_body", "rigid_body_id"},
    "mocap.base_markers": {"marker", "marker_set", "labeled_marker_id", "rigid_body", "rigid_body_id", "position_W_m"},
}


def _table(data: dict, key: str, where: str = "") -> dict:
    t = data.get(key)
    name = f"{where}.{key}" if where else key
    if t is None:
        raise HardwareConfigError(f"missing table [{name}]")
    return check_fields(t, CONFIG_FIELDS[name], name, HardwareConfigError)


def _address(table: dict, key: str, where: str, default=_MISSING) -> str:
    value = _field(table, key, where, str, default)
    try:
        ipaddress.IPv4Address(value)
    except ValueError:
        raise HardwareConfigError(f"field '{where}.{key}' must be an IPv4 address, got {value!r}") from None
    return value


def _port(table: dict, key: str, where: str, default: int) -> int:
    value = _field(table, key, where, int, default)
    if not 1 <= value <= 65535:
        raise HardwareConfigError(f"field '{where}.{key}' must be a UDP port 1..65535, got {value}")
    return value


def _motors(servos: dict, robot: RobotDescription) -> tuple:
    entries = servos.get("motor")
    if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
        raise HardwareConfigError("missing [[servos.motor]]: one table per cable")
    names = [c.name for c in robot.cables]
    if len(entries) != robot.n_cables:
        raise HardwareConfigError(
            f"[[servos.motor]] has {len(entries)} entries but robot {robot.name!r} has {robot.n_cables} cables {names}"
        )
    out = []
    for i, (entry, cable) in enumerate(zip(entries, names)):
        where = f"servos.motor[{i}]"
        check_fields(entry, CONFIG_FIELDS["servos.motor"], where, HardwareConfigError)
        if _field(entry, "cable", where, str) != cable:
            raise HardwareConfigError(
                f"field '{where}.cable' must be {cable!r} (the robot's cables in order: "
                f"{names}), got {entry['cable']!r}"
            )
        dxl_id = _field(entry, "id", where, int)
        if not 0 <= dxl_id <= 252:
            raise HardwareConfigError(f"field '{where}.id' must be a Dynamixel ID 0..252, got {dxl_id}")
        direction = _field(entry, "direction", where, int)
        if direction not in (1, -1):
            raise HardwareConfigError(f"field '{where}.direction' must be 1 or -1, got {direction}")
        out.append(ServoConfig(dxl_id, direction, _field(entry, "zero_offset_ticks", where, int), cable))
    ids = [s.dxl_id for s in out]
    if len(set(ids)) != len(ids):
        raise HardwareConfigError(f"servos.motor[].id must be distinct, got {ids}")
    return tuple(out)


def _marker(entry: dict, where: str, default_set: str | None) -> MarkerRef:
    keys = [k for k in ("marker", "labeled_marker_id", "rigid_body", "rigid_body_id") if k in entry]
    if len(keys) != 1:
        raise HardwareConfigError(
            f"'{where}' needs exactly one of marker, labeled_marker_id, rigid_body, rigid_body_id; got {keys or 'none'}"
        )
    key = keys[0]
    if key == "marker":
        marker_set = _field(entry, "marker_set", where, str, default_set)
        if marker_set is None:
            raise HardwareConfigError(
                f"'{where}.marker' needs a marker set: give '{where}.marker_set' or 'mocap.marker_set'"
            )
        return MarkerRef(marker=_field(entry, key, where, str), marker_set=marker_set)
    kind = int if key.endswith("_id") else str
    return MarkerRef(**{key: _field(entry, key, where, kind)})


def _natnet(mocap: dict) -> NatNetConfig:
    w = "mocap"
    transmission = _field(mocap, "transmission", w, str)
    if transmission not in ("unicast", "multicast"):
        raise HardwareConfigError(
            f'field \'mocap.transmission\' must be "unicast" or "multicast", got {transmission!r}'
        )
    unit = _field(mocap, "length_unit", w, str, "m")
    if unit not in LENGTH_UNITS_M:
        raise HardwareConfigError(f"field 'mocap.length_unit' must be one of {list(LENGTH_UNITS_M)}, got {unit!r}")
    default_set = _field(mocap, "marker_set", w, str, None)
    tip = _marker(_table(mocap, "tip", w), "mocap.tip", default_set)
    bases = mocap.get("base_markers")
    if not isinstance(bases, list) or len(bases) < 3 or not all(isinstance(b, dict) for b in bases):
        raise HardwareConfigError("[[mocap.base_markers]] needs at least 3 markers to define frame W")
    refs, positions = [], []
    for i, entry in enumerate(bases):
        where = f"mocap.base_markers[{i}]"
        check_fields(entry, CONFIG_FIELDS["mocap.base_markers"], where, HardwareConfigError)
        refs.append(_marker({k: v for k, v in entry.items() if k != "position_W_m"}, where, default_set))
        p = entry.get("position_W_m")
        if not (
            isinstance(p, list)
            and len(p) == 3
            and all(isinstance(c, (int, float)) and not isinstance(c, bool) and math.isfinite(c) for c in p)
        ):
            raise HardwareConfigError(f"field '{where}.position_W_m' must be a list of 3 numbers (m), got {p!r}")
        positions.append([float(c) for c in p])
    positions = np.array(positions)
    sv = np.linalg.svd(positions - positions.mean(axis=0), compute_uv=False)
    if sv[1] < 1e-3:
        raise HardwareConfigError(
            "mocap.base_markers[].position_W_m are (nearly) collinear: frame W needs 3 markers spread over the base"
        )
    return NatNetConfig(
        server_address=_address(mocap, "server_address", w),
        local_address=_address(mocap, "local_address", w),
        multicast=transmission == "multicast",
        tip=tip,
        base_markers=tuple(refs),
        base_positions_W_m=positions,
        multicast_address=_address(mocap, "multicast_address", w, "239.255.42.99"),
        command_port=_port(mocap, "command_port", w, 1510),
        data_port=_port(mocap, "data_port", w, 1511),
        length_unit_m=LENGTH_UNITS_M[unit],
        connect_timeout_s=_field(mocap, "connect_timeout_s", w, float, 5.0, positive=True),
        frame_timeout_s=_field(mocap, "frame_timeout_s", w, float, 0.5, positive=True),
        max_occlusion_s=_field(mocap, "max_occlusion_s", w, float, 2.0, nonneg=True),
        calibration_frames=_field(mocap, "calibration_frames", w, int, 600, positive=True),
        max_base_fit_rms_m=_field(mocap, "max_base_fit_rms_m", w, float, 0.003, positive=True),
        queue_frames=_field(mocap, "queue_frames", w, int, 1200, positive=True),
    )


#: Default Bus Watchdog period: servos whose host died (kill -9, a crash) stop within this.
DEFAULT_BUS_WATCHDOG_MS = 500


def _watchdog(servos: dict) -> float:
    ms = _field(servos, "bus_watchdog_ms", "servos", float, DEFAULT_BUS_WATCHDOG_MS, nonneg=True)
    if ms and not 20 <= ms <= 2540:
        raise HardwareConfigError(
            f"field 'servos.bus_watchdog_ms' must be 0 (off) or 20..2540 ms (the XM430 counts 20 ms units), got {ms}"
        )
    return ms


def parse_hardware_config(data: dict, robot: RobotDescription, source: str = "<dict>") -> HardwareConfig:
    """Validate a parsed TOML document for ``robot``."""
    check_fields(data, CONFIG_FIELDS[""], "", HardwareConfigError)
    if data.get("format_version") != FORMAT_VERSION:
        raise HardwareConfigError(
            f"field 'format_version' must be {FORMAT_VERSION}, got {data.get('format_version')!r}"
        )
    servos = _table(data, "servos")
    baud = _field(servos, "baud_rate", "servos", int)
    if baud not in SDK_BAUD_RATES:
        raise HardwareConfigError(f"field 'servos.baud_rate' must be one of {SDK_BAUD_RATES}, got {baud}")
    mocap = _table(data, "mocap")
    return HardwareConfig(
        source=source,
        port=_field(servos, "port", "servos", str),
        baud_rate=baud,
        servos=_motors(servos, robot),
        profile_velocity_rad_s=_field(servos, "profile_velocity_rad_s", "servos", float, positive=True),
        latency_timer_ms=_field(servos, "latency_timer_ms", "servos", float, 16.0, positive=True),
        start_margin_rad=_field(servos, "start_margin_rad", "servos", float, 0.5, nonneg=True),
        poll_interval_s=_field(servos, "poll_interval_s", "servos", float, 0.1, positive=True),
        frame_rate_hz=_field(mocap, "frame_rate_hz", "mocap", float, 120.0, positive=True),
        bus_watchdog_ms=_watchdog(servos),
        natnet=_natnet(mocap),
    )


def load_hardware_config(path: str | Path, robot: RobotDescription) -> HardwareConfig:
    """Read and validate a hardware rig TOML file for ``robot``."""
    path = Path(path)
    data = read_toml(path, HardwareConfigError, "hardware rig configuration")
    try:
        return parse_hardware_config(data, robot, str(path))
    except HardwareConfigError as err:
        raise HardwareConfigError(f"{path}: {err}") from None
