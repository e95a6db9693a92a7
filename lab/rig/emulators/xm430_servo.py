"""One emulated Dynamixel XM430: its control table, its spool and its hardware errors.

The register map is the XM430 control table of the ROBOTIS e-Manual (what a
position-controlled servo needs), with the rules a real servo enforces: EEPROM fields
written only with torque off, read-only fields and out-of-range goals or profile
velocities refused with the real error numbers, no torque while a hardware error is
latched, and the Bus Watchdog (address 98). The spool turns toward the goal at the
profile velocity on the bus clock and, released, back to its rest angle; the present
position reads within one turn after power-up, as on an X-series servo. The rules one by
one: ``docs/design/rig.md``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from lab.errors import InputError
from lab.rig.emulators import protocol2 as p2

TICKS_PER_REV = 4096
RPM_PER_VELOCITY_UNIT = 0.229
BAUD_BY_REGISTER = {0: 9600, 1: 57600, 2: 115200, 3: 1_000_000, 4: 2_000_000, 5: 3_000_000, 6: 4_000_000, 7: 4_500_000}
FAULTS = ("silent", "disconnected", "bad_crc", "crc_error", "overload")
OVERLOAD_BIT = 0x20
WATCHDOG_UNIT_S = 0.020

# XM430 control table (ROBOTIS e-Manual): address -> (name, size, writable, default)
FIELDS = {
    0: ("model_number", 2, False, 1020),
    2: ("model_information", 4, False, 0),
    6: ("firmware_version", 1, False, 48),
    7: ("id", 1, True, 1),
    8: ("baud_rate", 1, True, 1),
    9: ("return_delay_time", 1, True, 250),
    10: ("drive_mode", 1, True, 0),
    11: ("operating_mode", 1, True, 3),
    12: ("secondary_id", 1, True, 255),
    13: ("protocol_type", 1, True, 2),
    20: ("homing_offset", 4, True, 0),
    24: ("moving_threshold", 4, True, 10),
    31: ("temperature_limit", 1, True, 80),
    32: ("max_voltage_limit", 2, True, 160),
    34: ("min_voltage_limit", 2, True, 95),
    36: ("pwm_limit", 2, True, 885),
    38: ("current_limit", 2, True, 1193),
    44: ("velocity_limit", 4, True, 200),
    48: ("max_position_limit", 4, True, 4095),
    52: ("min_position_limit", 4, True, 0),
    63: ("shutdown", 1, True, 52),
    64: ("torque_enable", 1, True, 0),
    65: ("led", 1, True, 0),
    68: ("status_return_level", 1, True, 2),
    69: ("registered_instruction", 1, False, 0),
    70: ("hardware_error_status", 1, False, 0),
    76: ("velocity_i_gain", 2, True, 1920),
    78: ("velocity_p_gain", 2, True, 100),
    80: ("position_d_gain", 2, True, 0),
    82: ("position_i_gain", 2, True, 0),
    84: ("position_p_gain", 2, True, 800),
    88: ("feedforward_2nd_gain", 2, True, 0),
    90: ("feedforward_1st_gain", 2, True, 0),
    98: ("bus_watchdog", 1, True, 0),
    100: ("goal_pwm", 2, True, 885),
    102: ("goal_current", 2, True, 1193),
    104: ("goal_velocity", 4, True, 0),
    108: ("profile_acceleration", 4, True, 0),
    112: ("profile_velocity", 4, True, 0),
    116: ("goal_position", 4, True, 0),
    120: ("realtime_tick", 2, False, 0),
    122: ("moving", 1, False, 0),
    123: ("moving_status", 1, False, 0),
    124: ("present_pwm", 2, False, 0),
    126: ("present_current", 2, False, 0),
    128: ("present_velocity", 4, False, 0),
    132: ("present_position", 4, False, 0),
    136: ("velocity_trajectory", 4, False, 0),
    140: ("position_trajectory", 4, False, 0),
    144: ("present_input_voltage", 2, False, 120),
    146: ("present_temperature", 1, False, 35),
}
ADDR = {name: addr for addr, (name, *_rest) in FIELDS.items()}
TABLE_SIZE = 147
EEPROM_END = 64
EXTENDED_GOAL_LIMIT = 1_048_575


@dataclass(frozen=True)
class ServoSpec:
    """The physical truth of one emulated servo.

    Attributes
    ----------
    dxl_id : int
        Dynamixel ID, 0..252.
    zero_tick : int
        Spool angle (ticks, multi-turn; 4096 per revolution) where the cable is just taut (u = 0).
    direction : int
        +1 if increasing ticks wind the cable in, -1 if they let it out.
    start_tick : int or None
        Spool angle (ticks) at power-up; None: ``zero_tick``, the robot at rest.
    model_number : int
        The model number register (1020: XM430-W350).
    baud_rate : int
        The only baud rate (bit/s) the servo hears.
    max_speed_rad_s : float
        No-load speed of the spool (rad/s).
    backdrive_speed_rad_s : float
        Speed (rad/s) at which the foam pulls the spool back to ``zero_tick`` with torque off.
    """

    dxl_id: int
    zero_tick: int = 2048
    direction: int = 1
    start_tick: int | None = None
    model_number: int = 1020  # XM430-W350
    baud_rate: int = 57600
    max_speed_rad_s: float = 4.8  # no-load speed, 46 rev/min
    backdrive_speed_rad_s: float = 1.0


class EmulatedServo:
    """One XM430 at bus time ``t_s`` (s): control table, spool angle ``theta`` (ticks),
    fault state (set by the bus). Not thread-safe: the bus serialises access."""

    def __init__(self, spec: ServoSpec, t_s: float):
        if spec.direction not in (1, -1) or not 0 <= spec.dxl_id <= 252:
            raise InputError(f"servo spec needs an ID in 0..252 and direction +-1, got {spec}")
        self.spec = spec
        self.table = bytearray(TABLE_SIZE)
        for addr, (_name, size, _w, default) in FIELDS.items():
            self._set(addr, size, default)
        self._set(ADDR["id"], 1, spec.dxl_id)
        self._set(ADDR["model_number"], 2, spec.model_number)
        baud_reg = {v: k for k, v in BAUD_BY_REGISTER.items()}
        if spec.baud_rate not in baud_reg:
            raise InputError(f"servo {spec.dxl_id}: baud rate {spec.baud_rate} is not an XM430 rate")
        self._set(ADDR["baud_rate"], 1, baud_reg[spec.baud_rate])
        self.theta = float(spec.zero_tick if spec.start_tick is None else spec.start_tick)
        self.t_last = t_s
        self.encoder_offset = 0
        self.fault: str | None = None
        self.fault_count: int | None = None
        self.last_heard = t_s
        self.power_up(t_s)

    # --- registers ------------------------------------------------------------------
    def _set(self, addr: int, size: int, value: int) -> None:
        self.table[addr : addr + size] = int(value).to_bytes(size, "little", signed=value < 0)

    def get(self, name: str) -> int:
        addr = ADDR[name]
        size = FIELDS[addr][1]
        signed = name in (
            "homing_offset",
            "goal_position",
            "present_position",
            "present_velocity",
            "goal_velocity",
            "present_current",
            "present_pwm",
        )
        return int.from_bytes(self.table[addr : addr + size], "little", signed=signed)

    @property
    def dxl_id(self) -> int:
        return self.get("id")

    @property
    def baud_rate(self) -> int:
        return BAUD_BY_REGISTER.get(self.get("baud_rate"), -1)

    @property
    def torque_enabled(self) -> bool:
        return self.get("torque_enable") == 1

    @property
    def alert(self) -> int:
        return p2.ERR_ALERT if self.get("hardware_error_status") else 0

    # --- physics --------------------------------------------------------------------
    def power_up(self, t_s: float) -> None:
        """Power-up/REBOOT: torque off, errors cleared, position reported within one turn."""
        self.advance(t_s)
        self.encoder_offset = -TICKS_PER_REV * math.floor(self.theta / TICKS_PER_REV)
        for name in ("torque_enable", "hardware_error_status"):
            self._set(ADDR[name], 1, 0)
        self._set(ADDR["goal_position"], 4, round(self.theta) + self.encoder_offset)
        self._refresh(t_s, 0.0)

    def target_theta(self) -> float:
        if self.torque_enabled:
            return float(self.get("goal_position") - self.encoder_offset)
        return float(self.spec.zero_tick)  # released: the foam pulls the cable back

    def speed_ticks_s(self) -> float:
        if not self.torque_enabled:
            return self.spec.backdrive_speed_rad_s * TICKS_PER_REV / (2 * math.pi)
        v_max = self.spec.max_speed_rad_s * TICKS_PER_REV / (2 * math.pi)
        pv = self.get("profile_velocity")
        return v_max if pv == 0 else min(v_max, pv * RPM_PER_VELOCITY_UNIT / 60 * TICKS_PER_REV)

    def heard(self, t_s: float) -> None:
        """An instruction packet for this servo arrived at ``t_s`` (the Bus Watchdog's input)."""
        self._check_watchdog(t_s)
        self.last_heard = max(self.last_heard, t_s)

    def _check_watchdog(self, t_s: float) -> None:
        wd = int.from_bytes(self.table[ADDR["bus_watchdog"] : ADDR["bus_watchdog"] + 1], "little", signed=True)
        t_trip = self.last_heard + WATCHDOG_UNIT_S * wd
        if 1 <= wd <= 127 and self.torque_enabled and t_s > t_trip:
            self.advance(t_trip)  # the spool moved until the watchdog fired ...
            self._set(ADDR["goal_position"], 4, round(self.theta) + self.encoder_offset)  # ... and stops there
            self._set(ADDR["bus_watchdog"], 1, 0xFF)

    @property
    def watchdog_tripped(self) -> bool:
        return self.get("bus_watchdog") == 0xFF

    def advance(self, t_s: float) -> None:
        self._check_watchdog(t_s)
        dt = max(0.0, t_s - self.t_last)
        self.t_last = max(self.t_last, t_s)
        err = self.target_theta() - self.theta
        step = min(abs(err), self.speed_ticks_s() * dt)
        self.theta += math.copysign(step, err)
        self._refresh(t_s, math.copysign(self.speed_ticks_s(), err) if abs(err) > step else 0.0)

    def _refresh(self, t_s: float, velocity_ticks_s: float) -> None:
        self._set(ADDR["present_position"], 4, round(self.theta) + self.encoder_offset)
        self._set(ADDR["present_velocity"], 4, round(velocity_ticks_s * 60 / TICKS_PER_REV / RPM_PER_VELOCITY_UNIT))
        moving = abs(self.target_theta() - self.theta) > self.get("moving_threshold")
        self._set(ADDR["moving"], 1, int(moving))
        self._set(ADDR["realtime_tick"], 2, int(t_s * 1000) % 32768)

    def u_goal_rad(self) -> float:
        """Motor angle the body is commanded to (rad): 0 when released."""
        if not self.torque_enabled:
            return 0.0
        return self.spec.direction * (self.target_theta() - self.spec.zero_tick) * 2 * math.pi / TICKS_PER_REV

    def overload(self) -> None:
        self._set(ADDR["hardware_error_status"], 1, self.get("hardware_error_status") | OVERLOAD_BIT)
        if self.get("shutdown") & OVERLOAD_BIT:
            self._set(ADDR["torque_enable"], 1, 0)

    # --- instructions ---------------------------------------------------------------
    def read(self, addr: int, length: int, t_s: float) -> tuple[int, bytes]:
        self.advance(t_s)
        if length == 0 or addr + length > TABLE_SIZE:
            return p2.ERR_ACCESS | self.alert, b""
        return self.alert, bytes(self.table[addr : addr + length])

    def write(self, addr: int, data: bytes, t_s: float) -> int:
        """Apply a write; returns the error byte (nothing is written on an error)."""
        self.advance(t_s)
        end = addr + len(data)
        if not data or end > TABLE_SIZE:
            return p2.ERR_ACCESS | self.alert
        new = bytearray(self.table)
        new[addr:end] = data
        for f_addr, (_name, size, writable, _d) in FIELDS.items():
            if f_addr + size <= addr or f_addr >= end:
                continue
            if not writable:
                return p2.ERR_ACCESS | self.alert
            if f_addr < EEPROM_END and self.torque_enabled:
                return p2.ERR_ACCESS | self.alert
        gaps = [a for a in range(addr, end) if not any(f <= a < f + FIELDS[f][1] for f in FIELDS)]
        if gaps:
            return p2.ERR_ACCESS | self.alert
        value = (
            lambda name, signed=False: int.from_bytes(  # noqa: E731
                new[ADDR[name] : ADDR[name] + FIELDS[ADDR[name]][1]], "little", signed=signed
            )
        )
        if value("operating_mode") not in (0, 1, 3, 4, 5, 16):
            return p2.ERR_DATA_RANGE | self.alert
        goal = value("goal_position", signed=True)
        if value("operating_mode") == 4:
            goal_ok = -EXTENDED_GOAL_LIMIT <= goal <= EXTENDED_GOAL_LIMIT
        else:
            goal_ok = value("min_position_limit") <= goal <= value("max_position_limit")
        if addr < ADDR["goal_position"] + 4 and end > ADDR["goal_position"] and not goal_ok:
            return p2.ERR_DATA_LIMIT | self.alert
        goals = (ADDR["goal_pwm"], ADDR["goal_position"] + 4)
        if self.watchdog_tripped and addr < goals[1] and end > goals[0] and value("bus_watchdog") == 0xFF:
            return p2.ERR_DATA_RANGE | self.alert  # goals are locked until the watchdog is cleared
        if not (value("bus_watchdog") <= 127 or value("bus_watchdog") == 0xFF):
            return p2.ERR_DATA_RANGE | self.alert
        if value("profile_velocity") > value("velocity_limit"):
            return p2.ERR_DATA_LIMIT | self.alert
        torque_on_request = value("torque_enable") == 1 and not self.torque_enabled
        if torque_on_request and self.get("hardware_error_status"):
            new[ADDR["torque_enable"]] = 0  # refused until REBOOT; the alert bit says why
        self.table[:] = new
        if torque_on_request and self.torque_enabled:
            self._set(ADDR["goal_position"], 4, round(self.theta) + self.encoder_offset)
        self._refresh(t_s, 0.0)
        return self.alert
