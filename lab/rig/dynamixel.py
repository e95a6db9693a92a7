"""Dynamixel XM430 servos on one bus, through the real ``dynamixel_sdk`` (Protocol 2.0).

``XM430Bus`` opens the serial port, pings every servo, switches torque off, sets extended position
mode and the profile velocity, then moves all motors at once, each at a speed scaled to its travel
so that all arrive together (``write_goal_u``, sync writes), and reads them back
(``read_present_u``, a sync read checking every error byte). Motor angle ``u`` (rad) >= 0 winds the
cable in; per servo ``u = direction * (ticks - zero_ticks) * 2 pi / 4096``, with each zero moved by
whole turns on connecting to the turn nearest u = 0 (an X-series servo reports within one turn), and
a start-up angle outside the allowed range refused. The Bus Watchdog is cleared on connecting (a
killed session leaves it fired, locking goals and profile) and re-armed, the last goal written
again, after any quiet spell it may have fired in. Every failed exchange raises ``ServoError``
naming the servo ID and its cable, after trying to switch torque off on every servo (the message
says whether that was confirmed). Details: ``docs/design/rig.md``.
"""

from __future__ import annotations

import math
import termios
import time
from collections.abc import Sequence

import numpy as np
import serial
from dynamixel_sdk import (
    BROADCAST_ID,
    COMM_SUCCESS,
    GroupSyncRead,
    GroupSyncWrite,
    PacketHandler,
)

from lab.errors import InputError
from lab.rig.base import ServoError
from lab.rig.dynamixel_units import (
    BUS_WATCHDOG,
    BUS_WATCHDOG_UNIT_MS,
    EXTENDED_POSITION_MODE,
    GOAL_LIMIT_TICKS,
    GOAL_POSITION,
    HARDWARE_ERROR_BITS,
    HARDWARE_ERROR_STATUS,
    OPERATING_MODE,
    PRESENT_POSITION,
    PROFILE_VELOCITY,
    RAD_PER_TICK,
    READ_TRIES,
    RPM_PER_VELOCITY_UNIT,
    SDK_BAUD_RATES,
    TICKS_PER_REV,
    TORQUE_ENABLE,
    VELOCITY_LIMIT,
    X_SERIES_MODELS,
    ServoConfig,
    bytes4,
    synced_velocity_units,
    ticks_from_u,
    u_from_ticks,
    velocity_units,
)
from lab.rig.dynamixel_units import (
    LatencyPortHandler as _PortHandler,
)

__all__ = [
    "XM430Bus",
    "ServoConfig",
    "ticks_from_u",
    "u_from_ticks",
    "velocity_units",
    "RAD_PER_TICK",
    "TICKS_PER_REV",
    "SDK_BAUD_RATES",
    "X_SERIES_MODELS",
    "IO_ERRORS",
]

# what pyserial raises when the adapter goes away (termios.error is no OSError)
IO_ERRORS = (serial.SerialException, OSError, termios.error)

#: A quiet bus for longer than this fraction of the Bus Watchdog time may have fired it: the servo
#: times from a packet's arrival, the host from the end of an exchange (they differ by delays).
WATCHDOG_MARGIN = 0.5


class XM430Bus:
    """A connected, configured bus of XM430 servos (torque off until ``torque_on``).

    ``servos`` are in motor (cable) order; ``profile_velocity_rad_s`` caps each spool's speed;
    ``u_max_rad`` with ``start_margin_rad`` bounds the accepted start-up angles; ``clock`` (s)
    times quiet spells for the Bus Watchdog; ``reply_timer`` (s) the status-packet timeout
    (wall clock if None). Raises ``ServoError`` (port closed, torque off) if any of it fails."""

    def __init__(
        self,
        port: str,
        baud_rate: int,
        servos: Sequence[ServoConfig],
        *,
        profile_velocity_rad_s: float,
        u_max_rad: float = math.pi,
        start_margin_rad: float = 0.5,
        latency_timer_ms: float = 16.0,
        bus_watchdog_ms: float = 0.0,
        clock=time.monotonic,
        reply_timer=None,
    ):
        self.servos = tuple(servos)
        self.ids = [s.dxl_id for s in self.servos]
        if not self.ids or len(set(self.ids)) != len(self.ids) or not all(0 <= i <= 252 for i in self.ids):
            raise InputError(f"servo IDs must be distinct integers in 0..252, got {self.ids}")
        if any(s.direction not in (1, -1) for s in self.servos):
            raise InputError(f"servo directions must be +1 or -1, got {[s.direction for s in self.servos]}")
        if baud_rate not in SDK_BAUD_RATES:
            raise InputError(f"baud rate {baud_rate} is not one the Dynamixel SDK supports: {SDK_BAUD_RATES}")
        if not profile_velocity_rad_s > 0:
            raise InputError(f"profile velocity must be positive, got {profile_velocity_rad_s} rad/s")
        self.port_name, self.baud_rate = str(port), int(baud_rate)
        self.direction = np.array([s.direction for s in self.servos])
        self.zero_ticks = np.array([s.zero_offset_ticks for s in self.servos], dtype=np.int64)
        self.profile_velocity_rad_s = float(profile_velocity_rad_s)
        self.profile_velocity_units = velocity_units(profile_velocity_rad_s)
        # Bus Watchdog: a servo that hears nothing for this long stops by itself (the host died).
        self.watchdog_units = min(127, max(1, round(bus_watchdog_ms / BUS_WATCHDOG_UNIT_MS))) if bus_watchdog_ms else 0
        self.watchdog_s = self.watchdog_units * BUS_WATCHDOG_UNIT_MS / 1000
        self._clock, self._t_io = clock, clock()
        self._watchdog_armed = self._watchdog_lapsed = False  # lapsed: it may have fired since armed
        self._goal_ticks = self._present_ticks = None  # (n,) ticks: the last goal written, positions read
        self.model_numbers: dict[int, int] = {}
        self._closed = False
        self._unconfirmed_at_fail: list[int] | None = None  # torque-off result of the last failure
        self._ph = PacketHandler(2.0)
        self._port = _PortHandler(self.port_name, latency_timer_ms, reply_timer)
        try:
            ok = self._port.setBaudRate(self.baud_rate)  # opens the port
        except IO_ERRORS as err:
            self._closed = True
            raise ServoError(f"cannot open serial port {self.port_name}: {err}") from None
        if not ok:
            self._closed = True
            raise ServoError(f"serial port {self.port_name} refused {self.baud_rate} baud")
        self._sync_write = GroupSyncWrite(self._port, self._ph, *GOAL_POSITION)
        self._profile_write = GroupSyncWrite(self._port, self._ph, *PROFILE_VELOCITY)
        self._sync_read = GroupSyncRead(self._port, self._ph, *PRESENT_POSITION)
        for dxl_id in self.ids:
            self._sync_read.addParam(dxl_id)
        try:
            self._configure(u_max_rad, start_margin_rad)
        except BaseException:
            self.close()
            raise

    # --- set-up ---------------------------------------------------------------------
    def _configure(self, u_max_rad: float, start_margin_rad: float) -> None:
        for s in self.servos:
            model, result, error = self._sdk(self._ph.ping, self._port, s.dxl_id)
            if result != COMM_SUCCESS:
                self._fail(
                    s.dxl_id,
                    f"ping on {self.port_name} at {self.baud_rate} baud",
                    self._ph.getTxRxResult(result) + " (check power, wiring, ID and baud rate)",
                )
            self._check(s.dxl_id, "ping", result, error)
            if model not in X_SERIES_MODELS:
                self._fail(
                    s.dxl_id,
                    "model check",
                    f"model number {model} is not an X-series servo "
                    f"with the XM430 control table ({sorted(X_SERIES_MODELS)})",
                )
            self.model_numbers[s.dxl_id] = model
        for s in self.servos:
            self.write_register(s.dxl_id, *TORQUE_ENABLE, 0)
            self.write_register(s.dxl_id, *BUS_WATCHDOG, 0)  # fired (host killed): locks goals and profile
            if self.read_register(s.dxl_id, *OPERATING_MODE) != EXTENDED_POSITION_MODE:
                self.write_register(s.dxl_id, *OPERATING_MODE, EXTENDED_POSITION_MODE)  # EEPROM: only if needed
            limit = self.read_register(s.dxl_id, *VELOCITY_LIMIT)
            if self.profile_velocity_units > limit:
                self._fail(
                    s.dxl_id,
                    "profile velocity check",
                    f"{self.profile_velocity_rad_s} rad/s ({self.profile_velocity_units} units of "
                    f"{RPM_PER_VELOCITY_UNIT} rev/min) exceeds the servo's Velocity Limit (address 44) of "
                    f"{limit} units = {limit * RPM_PER_VELOCITY_UNIT * 2 * math.pi / 60:.2f} rad/s",
                )
            self.write_register(s.dxl_id, *PROFILE_VELOCITY, self.profile_velocity_units)
        ticks = self.read_present_ticks()
        turns = np.rint((ticks - self.zero_ticks) / TICKS_PER_REV).astype(np.int64)
        self.zero_ticks = self.zero_ticks + TICKS_PER_REV * turns
        u = self.u_from_ticks(ticks)
        for s, u_i in zip(self.servos, u):
            if not -start_margin_rad <= u_i <= u_max_rad + start_margin_rad:
                self._fail(
                    s.dxl_id,
                    "start-up check",
                    f"spool at u = {u_i:.3f} rad, outside [{-start_margin_rad}, {u_max_rad + start_margin_rad}] "
                    "rad: check zero_offset_ticks and direction, or unwind the spool by hand",
                )

    # --- conversions ----------------------------------------------------------------
    def ticks_from_u(self, u_rad) -> np.ndarray:
        return ticks_from_u(u_rad, self.zero_ticks, self.direction)

    def u_from_ticks(self, ticks) -> np.ndarray:
        return u_from_ticks(ticks, self.zero_ticks, self.direction)

    # --- motion ---------------------------------------------------------------------
    def torque_on(self) -> None:
        """Hold the present positions (goal := present), then enable torque on every servo."""
        self._unconfirmed_at_fail = None
        self.write_goal_ticks(self.read_present_ticks())
        for dxl_id in self.ids:
            self.write_register(dxl_id, *TORQUE_ENABLE, 1)
        for dxl_id in self.ids:
            if self.read_register(dxl_id, *TORQUE_ENABLE) != 1:
                self._fail(dxl_id, "torque on", "torque enable did not stick")
        self.arm_watchdog()

    def arm_watchdog(self) -> None:
        """(Re)start every servo's Bus Watchdog: clear a fired one (-1) and set the period.
        With torque on, a servo that then hears no packet for ``watchdog_s`` stops by itself."""
        if self.watchdog_units:
            for dxl_id in self.ids:
                self.write_register(dxl_id, *BUS_WATCHDOG, 0)
                self.write_register(dxl_id, *BUS_WATCHDOG, self.watchdog_units)
            self._watchdog_armed, self._watchdog_lapsed = True, False

    def _watchdog_may_have_fired(self) -> bool:
        """Whether, since it was armed, the bus was quiet for long enough (checked before every exchange)."""
        if self._watchdog_armed and self._clock() - self._t_io > WATCHDOG_MARGIN * self.watchdog_s:
            self._watchdog_lapsed = True
        return self._watchdog_lapsed

    def write_goal_u(self, u_rad) -> np.ndarray:
        """Sync-write goal angles ``u_rad`` (n,) rad; returns the goal ticks sent."""
        u = np.asarray(u_rad, dtype=float)
        if u.shape != (len(self.ids),) or not np.all(np.isfinite(u)):
            raise InputError(f"expected {len(self.ids)} finite motor angles, got {u!r}")
        ticks = self.ticks_from_u(u)
        self.write_goal_ticks(ticks)
        return ticks

    def write_goal_ticks(self, ticks) -> None:
        """Sync-write raw goal positions (n,) ticks (no status packets come back), after profile
        velocities that bring every servo there together from the positions last read."""
        ticks = np.asarray(ticks, dtype=np.int64)
        for dxl_id, t in zip(self.ids, ticks):
            if abs(int(t)) > GOAL_LIMIT_TICKS:
                raise InputError(f"servo ID {dxl_id}: goal {int(t)} ticks outside +-{GOAL_LIMIT_TICKS}")
        if self._watchdog_may_have_fired():
            self.arm_watchdog()  # a fired one locks the goals, and a sync write gets no answer to say so
        if self._present_ticks is not None:
            speeds = synced_velocity_units(ticks - self._present_ticks, self.profile_velocity_units)
            self._write_all(self._profile_write, speeds, "profile velocities")
        self._write_all(self._sync_write, ticks, "goal positions")
        self._goal_ticks = ticks.copy()

    def _write_all(self, group: GroupSyncWrite, values, what: str) -> None:
        group.clearParam()
        for dxl_id, v in zip(self.ids, values):
            group.addParam(dxl_id, bytes4(v))
        self._check(self.ids[0], f"sync write of {what}", self._sdk(group.txPacket), 0, who="bus")

    def read_present_ticks(self) -> np.ndarray:
        """Sync-read present positions (n,) ticks (signed), checking each status packet; first,
        if the watchdog may have fired, re-arm it and write the last goal again (stopped servos go on)."""
        if self._watchdog_may_have_fired() and self._goal_ticks is not None:
            self.write_goal_ticks(self._goal_ticks)  # which re-arms it first
        for attempt in range(READ_TRIES):  # a status packet lost to the reply timeout is asked for again
            result = self._sdk(self._sync_read.txPacket)
            self._check(self.ids[0], "sync read of present positions", result, 0, who="bus")
            replies = [self._sdk(self._ph.readRx, self._port, i, PRESENT_POSITION[1]) for i in self.ids]
            if attempt == READ_TRIES - 1 or all(r[1] == COMM_SUCCESS for r in replies):
                break
            self._port.clearPort()  # a late answer must not be read as the next one
        out = np.zeros(len(self.ids), dtype=np.int64)
        for k, (dxl_id, (data, result, error)) in enumerate(zip(self.ids, replies)):
            self._check(dxl_id, "sync read of present position", result, error)
            out[k] = int.from_bytes(bytes(data[:4]), "little", signed=True)
        self._present_ticks = out.copy()
        return out

    def read_present_u(self) -> np.ndarray:
        """Present motor angles (n,) rad."""
        return self.u_from_ticks(self.read_present_ticks())

    # --- registers ------------------------------------------------------------------
    def _read_raw(self, dxl_id: int, address: int, size: int) -> tuple[int | None, int, int]:
        """(value or None, comm result, error byte). Uses the SDK's generic ``readTxRx``:
        its ``readNByteTxRx`` index an empty data list when an error status carries no data."""
        data, result, error = self._ph.readTxRx(self._port, dxl_id, address, size)
        if result != COMM_SUCCESS or len(data) < size:
            return None, result, error
        return int.from_bytes(bytes(data[:size]), "little", signed=size == 4), result, error

    def read_register(self, dxl_id: int, address: int, size: int, *, alert_ok: bool = False) -> int:
        """Read a 1/2/4-byte register (4-byte values signed)."""
        value, result, error = self._sdk(self._read_raw, dxl_id, address, size)
        self._check(dxl_id, f"read of address {address}", result, error, alert_ok=alert_ok)
        if value is None:
            self._fail(dxl_id, f"read of address {address}", "status packet without data")
        return value

    def write_register(self, dxl_id: int, address: int, size: int, value: int) -> None:
        """Write a 1/2/4-byte register and check the servo's answer."""
        fn = {1: self._ph.write1ByteTxRx, 2: self._ph.write2ByteTxRx, 4: self._ph.write4ByteTxRx}[size]
        result, error = self._sdk(fn, self._port, dxl_id, address, int(value) & 0xFFFFFFFF)
        self._check(dxl_id, f"write of {value} to address {address}", result, error)

    def read_hardware_errors(self) -> dict[int, int]:
        """Hardware error status register (address 70) of every servo, by ID."""
        return {i: self.read_register(i, *HARDWARE_ERROR_STATUS, alert_ok=True) for i in self.ids}

    # --- errors and shutdown --------------------------------------------------------
    def _sdk(self, fn, *args):
        self._watchdog_may_have_fired()
        try:
            out = fn(*args)
            self._t_io = self._clock()
            return out
        except IO_ERRORS as err:
            self._fail(None, "serial I/O", f"port {self.port_name} failed: {err}")

    def _cable(self, dxl_id) -> str:
        cable = next((s.cable for s in self.servos if s.dxl_id == dxl_id), "")
        return f" (cable {cable!r})" if cable else ""

    def _check(self, dxl_id, what, result, error, *, alert_ok=False, who=None) -> None:
        if result != COMM_SUCCESS:
            self._fail(None if who else dxl_id, what, self._ph.getTxRxResult(result))
        if error & 0x7F:
            self._fail(dxl_id, what, self._ph.getRxPacketError(error & 0x7F))
        if error & 0x80 and not alert_ok:
            self._fail(dxl_id, what, self._ph.getRxPacketError(0x80) + self._hardware_error_text(dxl_id))

    def _hardware_error_text(self, dxl_id: int) -> str:
        try:
            status, _result, _error = self._read_raw(dxl_id, *HARDWARE_ERROR_STATUS)
        except IO_ERRORS:
            return ""
        if status is None:
            return ""
        names = [name for bit, name in HARDWARE_ERROR_BITS.items() if status & (1 << bit)]
        return f" hardware error status 0x{status:02X}: {', '.join(names) or 'unknown'}"

    def _fail(self, dxl_id, what: str, message: str):
        unconfirmed = self._unconfirmed_at_fail = self.torque_off()
        note = (
            "torque is off on every servo"
            if not unconfirmed
            else f"torque off NOT confirmed for servo IDs {unconfirmed}: switch off servo power"
        )
        who = "servo bus" if dxl_id is None else f"servo ID {dxl_id}{self._cable(dxl_id)}"
        raise ServoError(f"{who} on {self.port_name}: {what} failed: {message} [{note}]")

    def torque_off(self) -> list[int]:
        """Best effort, never raises: broadcast torque off, then read torque enable back from
        each servo (if not 0: write it once more, read again). Returns the IDs whose torque
        off could not be confirmed."""
        self._watchdog_armed = False
        if self._port.ser is None or not self._port.is_open:
            return list(self.ids)
        unconfirmed = []

        def is_off(dxl_id):
            return self._read_raw(dxl_id, *TORQUE_ENABLE)[0] == 0

        try:
            self._port.is_using = False  # an interrupted exchange may have left it set
            self._ph.write1ByteTxOnly(self._port, BROADCAST_ID, TORQUE_ENABLE[0], 0)
            for dxl_id in self.ids:
                if not is_off(dxl_id):
                    self._ph.write1ByteTxRx(self._port, dxl_id, TORQUE_ENABLE[0], 0)
                    if not is_off(dxl_id):
                        unconfirmed.append(dxl_id)
        except IO_ERRORS:
            return list(self.ids)
        return unconfirmed

    def close(self) -> list[int]:
        """Torque off and close the port (idempotent). Returns the IDs whose torque off is not
        confirmed (a failure's own torque-off result, if torque was not enabled since)."""
        if self._closed:
            return []
        self._closed = True
        unconfirmed = self._unconfirmed_at_fail
        if unconfirmed is None:
            unconfirmed = self.torque_off()
        try:
            self._port.closePort()
        except (*IO_ERRORS, AttributeError):
            pass
        return unconfirmed

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False
