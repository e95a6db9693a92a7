"""Dynamixel X-series numbers: the control table addresses the driver uses, model numbers,
and the conversions between motor angle u (rad) and servo units.

Ticks: 4096 per revolution; ``u = direction * (ticks - zero_ticks) * 2 pi / 4096`` with
``direction`` = +1 if increasing ticks wind the cable in (u >= 0 contracts the cable by
``spool_radius_m * u``). Velocity: units of 0.229 rev/min.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from dynamixel_sdk import PortHandler

TICKS_PER_REV = 4096
RAD_PER_TICK = 2 * math.pi / TICKS_PER_REV
RPM_PER_VELOCITY_UNIT = 0.229
EXTENDED_POSITION_MODE = 4
GOAL_LIMIT_TICKS = 1_048_575  # extended position mode range of the goal
SDK_BAUD_RATES = (
    9600,
    19200,
    38400,
    57600,
    115200,
    230400,
    460800,
    500000,
    576000,
    921600,
    1000000,
    1152000,
    2000000,
    2500000,
    3000000,
    3500000,
    4000000,
)

# XM430 control table (ROBOTIS e-Manual): (address, size in bytes)
OPERATING_MODE = (11, 1)
VELOCITY_LIMIT = (44, 4)
TORQUE_ENABLE = (64, 1)
#: Bus Watchdog: stop when no packet came for value x 20 ms (0 off; reads -1 = 255 once fired).
BUS_WATCHDOG = (98, 1)
BUS_WATCHDOG_UNIT_MS = 20
HARDWARE_ERROR_STATUS = (70, 1)
PROFILE_VELOCITY = (112, 4)
GOAL_POSITION = (116, 4)
PRESENT_POSITION = (132, 4)

HARDWARE_ERROR_BITS = {0: "input voltage", 2: "overheating", 3: "motor encoder", 4: "electrical shock", 5: "overload"}
# X-series servos sharing the XM430 addresses used here (model number -> name); extend
# this table for another model with the same addresses 11, 44, 64, 70, 112, 116, 132.
X_SERIES_MODELS = {
    1000: "XH430-W350",
    1001: "XD430-T350",
    1010: "XH430-W210",
    1011: "XD430-T210",
    1020: "XM430-W350",
    1030: "XM430-W210",
    1040: "XH430-V350",
    1050: "XH430-V210",
    1060: "XL430-W250",
    1070: "XC430-W150",
    1080: "XC430-W240",
    1100: "XH540-W270",
    1110: "XH540-W150",
    1120: "XM540-W270",
    1130: "XM540-W150",
    1270: "XW430-T333",
    1280: "XW430-T200",
}


@dataclass(frozen=True)
class ServoConfig:
    """One motor: its bus ``dxl_id``, ``direction`` (+1/-1), ``zero_offset_ticks`` and the
    ``cable`` it pulls (for messages)."""

    dxl_id: int
    direction: int = 1
    zero_offset_ticks: int = 0
    cable: str = ""


def ticks_from_u(u_rad, zero_ticks, direction) -> np.ndarray:
    """Goal ticks (int64) for motor angles ``u_rad`` (n,) rad, rounded to the nearest tick."""
    steps = np.rint(np.asarray(u_rad, dtype=float) / RAD_PER_TICK).astype(np.int64)
    return np.asarray(zero_ticks, dtype=np.int64) + np.asarray(direction, dtype=np.int64) * steps


def u_from_ticks(ticks, zero_ticks, direction) -> np.ndarray:
    """Motor angles (n,) rad for present positions ``ticks`` (n,)."""
    d_ticks = np.asarray(ticks, dtype=np.int64) - np.asarray(zero_ticks, dtype=np.int64)
    return np.asarray(direction, dtype=float) * d_ticks * RAD_PER_TICK + 0.0  # no -0.0


def velocity_units(omega_rad_s: float) -> int:
    """Profile velocity register value (units of 0.229 rev/min, at least 1) for rad/s."""
    return max(1, round(omega_rad_s * 60 / (2 * math.pi) / RPM_PER_VELOCITY_UNIT))


def synced_velocity_units(travel_ticks, pace_units: int) -> np.ndarray:
    """Profile velocities (n,) in register units that bring every servo to its goal at the
    same time: the longest travel ``travel_ticks`` (n,) at ``pace_units``, each other in
    proportion (to the nearest unit, at least 1: 0 would be the servo's top speed). A servo
    that does not move keeps the pace. Each servo turns at constant speed (profile
    acceleration 0), so the motor angles move on a straight line from start to goal -- the
    move the capture's recorder and the relaxation filter assume -- but for the whole units
    (0.229 rev/min): a servo at k units arrives up to 0.5 / k of its travel time early or late."""
    travel = np.abs(np.asarray(travel_ticks, dtype=float))
    longest = float(travel.max()) if travel.size else 0.0
    if longest <= 0:
        return np.full(travel.shape, int(pace_units), dtype=np.int64)
    units = np.maximum(np.rint(int(pace_units) * travel / longest), 1).astype(np.int64)
    return np.where(travel > 0, units, int(pace_units))


def bytes4(value: int) -> list[int]:
    """A 4-byte register value, little endian (two's complement), as a sync write's parameter."""
    return list((int(value) & 0xFFFFFFFF).to_bytes(4, "little"))


#: How often a sync read whose status packets timed out is sent again before it counts as failed.
READ_TRIES = 3


class LatencyPortHandler(PortHandler):
    """The SDK's port with the reply timeout computed from the adapter's actual latency
    timer (the SDK hard-codes 16 ms: it waits 2 x latency + 2 ms for a status packet).

    ``reply_timer`` (s, optional) is what the timeout is measured on; the SDK's default is the
    wall clock. Emulated hardware passes ``time.thread_time``: the emulated bus is a thread of
    the same process, and a loaded machine that leaves the process no CPU must not turn into a
    lost packet, while a silent servo still times out after the same time spent polling.
    """

    def __init__(self, port_name: str, latency_timer_ms: float, reply_timer=None):
        super().__init__(port_name)
        self.latency_timer_ms = float(latency_timer_ms)
        self._reply_timer = reply_timer

    def getCurrentTime(self):
        if self._reply_timer is None:
            return super().getCurrentTime()
        return self._reply_timer() * 1000.0  # ms, as the SDK counts

    def setPacketTimeout(self, packet_length):
        self.packet_start_time = self.getCurrentTime()
        self.packet_timeout = self.tx_time_per_byte * packet_length + 2.0 * self.latency_timer_ms + 2.0
