"""An emulated bus of Dynamixel XM430 servos on a pseudo-terminal (Protocol 2.0).

``EmulatedXM430Bus`` opens a pty whose slave path (``bus.port``) the real
``dynamixel_sdk.PortHandler`` opens as it would ``/dev/ttyUSB0``; a background thread
answers PING, READ, WRITE, SYNC_READ, SYNC_WRITE and REBOOT (``protocol2.py``). Each servo
(``xm430_servo.EmulatedServo``) hears only its own baud rate. The physical truth of a motor
is its ``ServoSpec`` (``zero_tick``, ``direction``); with a ``LiveBody`` attached, goal,
speed and torque changes command the emulated body (each motor at its servo's speed) from
a worker thread, so a slow FEM solve never delays a status packet. Time is ``clock`` (wall
clock, or a shared ``VirtualClock``). Faults (``inject_fault``): ``"silent"``,
``"disconnected"``, ``"bad_crc"``, ``"crc_error"``, ``"overload"`` (until REBOOT), ``count``
times; ``unplug()`` closes the pty. Details: ``docs/design/rig.md``.
"""

from __future__ import annotations

import array
import fcntl
import os
import queue
import select
import struct
import threading
import time
import tty

import numpy as np

from lab.errors import InputError
from lab.rig.emulators import protocol2 as p2
from lab.rig.emulators.bodies import LiveBody
from lab.rig.emulators.xm430_servo import (
    FAULTS,
    TICKS_PER_REV,
    EmulatedServo,
    ServoSpec,
)

__all__ = ["EmulatedXM430Bus", "ServoSpec", "FAULTS"]


class EmulatedXM430Bus:
    """XM430 servos on a pseudo-terminal; ``port`` is the device path for the SDK.

    Use as a context manager (or ``start()``/``stop()``); the serving thread always stops.
    ``max_packet_gap_s`` is the longest time between two instruction packets (a test may
    reset it to 0): how long the host left the servos' Bus Watchdog unfed.

    Parameters
    ----------
    specs : iterable of ServoSpec
        The servos' physical truth, unique IDs; motor ``i`` of the body is ``specs[i]``.
    body : Body or LiveBody, optional
        The arm the servos drive (a ``Body`` is wrapped in a wall-clock ``LiveBody``);
        None: servos without a load.
    clock : callable
        Returns the time (s), e.g. ``time.monotonic`` or a ``VirtualClock``.
    """

    def __init__(self, specs, *, body=None, clock=time.monotonic):
        self.specs = tuple(specs)
        ids = [s.dxl_id for s in self.specs]
        if len(set(ids)) != len(ids):
            raise InputError(f"duplicate servo IDs {ids}")
        self._clock = clock
        self._t0 = clock()
        self.servos = [EmulatedServo(s, 0.0) for s in self.specs]
        self.body = body if body is None or isinstance(body, LiveBody) else LiveBody(body)
        self._lock = threading.RLock()
        self._reader = p2.PacketReader()
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)
        self.port = os.ttyname(self._slave)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._body_thread: threading.Thread | None = None
        self._body_queue: queue.Queue = queue.Queue()
        self._last_body_command: tuple | None = None
        self.body_error: BaseException | None = None
        self.packets = 0
        self.max_packet_gap_s = 0.0
        self._t_last_packet: float | None = None

    # --- lifecycle ------------------------------------------------------------------
    def start(self) -> EmulatedXM430Bus:
        """Start serving the pty (and driving the body, if any).

        Returns
        -------
        EmulatedXM430Bus
            ``self``, serving.
        """
        self._thread = threading.Thread(target=self._serve, name="xm430-bus", daemon=True)
        self._thread.start()
        if self.body is not None:
            self._body_thread = threading.Thread(target=self._drive_body, name="xm430-body", daemon=True)
            self._body_thread.start()
            self._command_body()
        return self

    def stop(self) -> None:
        """Stop the threads and close the pty (the SDK's next read or write fails)."""
        self._stop.set()
        self._body_queue.put(None)
        for thread in (self._thread, self._body_thread):
            if thread is not None:
                thread.join(timeout=30.0)
        for fd in (self._master, self._slave):
            try:
                os.close(fd)
            except OSError:
                pass
        self._master = self._slave = -1

    unplug = stop  # the USB adapter pulled out: the SDK's next read/write fails

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.stop()
        return False

    # --- inspection and faults ------------------------------------------------------
    def now(self) -> float:
        """The bus time.

        Returns
        -------
        float
            Seconds (on ``clock``) since construction.
        """
        return self._clock() - self._t0

    def servo(self, dxl_id: int) -> EmulatedServo:
        """The emulated servo with ID ``dxl_id`` (KeyError if there is none).

        Parameters
        ----------
        dxl_id : int
            The servo's Dynamixel ID (0..252).

        Returns
        -------
        EmulatedServo
            Its control table, spool angle and fault state.
        """
        for s in self.servos:
            if s.dxl_id == dxl_id:
                return s
        raise KeyError(f"no emulated servo with ID {dxl_id}")

    def state(self, dxl_id: int) -> dict:
        """Registers of one servo after advancing it to now (for tests).

        Parameters
        ----------
        dxl_id : int
            The servo's Dynamixel ID.

        Returns
        -------
        dict
            ``torque_enable``, ``operating_mode``, ``profile_velocity``, ``goal_position``,
            ``present_position`` (ticks), ``hardware_error_status``, ``moving`` (raw register
            values) and ``u_goal_rad``, the goal as a motor angle (rad).
        """
        with self._lock:
            s = self.servo(dxl_id)
            s.advance(self.now())
            names = (
                "torque_enable",
                "operating_mode",
                "profile_velocity",
                "goal_position",
                "present_position",
                "hardware_error_status",
                "moving",
            )
            return {n: s.get(n) for n in names} | {"u_goal_rad": s.u_goal_rad()}

    def inject_fault(self, dxl_id: int, fault: str, count: int | None = None) -> None:
        """Make one servo misbehave.

        Parameters
        ----------
        dxl_id : int
            The servo's Dynamixel ID.
        fault : str
            One of :data:`FAULTS`: ``silent`` (no status replies), ``disconnected`` (hears
            nothing), ``bad_crc`` (replies with a corrupted CRC), ``crc_error`` (reports a
            CRC error), ``overload`` (sets the overload bit of the hardware error status;
            torque off where the shutdown register says so, until REBOOT).
        count : int, optional
            How many replies the fault affects; None: until :meth:`clear_fault`.
        """
        if fault not in FAULTS:
            raise InputError(f"unknown fault {fault!r}; expected one of {FAULTS}")
        with self._lock:
            s = self.servo(dxl_id)
            s.advance(self.now())
            if fault == "overload":
                s.overload()
            else:
                s.fault, s.fault_count = fault, count
        self._command_body()

    def clear_fault(self, dxl_id: int) -> None:
        """End an injected communication fault of one servo (an overload needs a REBOOT).

        Parameters
        ----------
        dxl_id : int
            The servo's Dynamixel ID.
        """
        with self._lock:
            self.servo(dxl_id).fault = None

    # --- serving --------------------------------------------------------------------
    def _port_baud(self) -> int | None:
        """Baud rate the SDK set on the port (Linux termios2), None where unreadable."""
        try:
            buf = array.array("i", [0] * 64)
            fcntl.ioctl(self._slave, 0x802C542A, buf)  # TCGETS2: c_ispeed at word 9
            return int(buf[9])
        except OSError:
            return None

    def _serve(self) -> None:
        while not self._stop.is_set():
            try:
                ready, _, _ = select.select([self._master], [], [], 0.05)
                if not ready:
                    continue
                data = os.read(self._master, 4096)
            except (OSError, ValueError):
                return
            for pkt in self._reader.feed(data):
                with self._lock:
                    replies = self._handle(pkt)
                self._command_body()
                for reply in replies:
                    try:
                        os.write(self._master, reply)
                    except OSError:
                        return

    def _command_body(self) -> None:
        """Queue a body command if the servos' goals, torque or speed changed."""
        if self.body is None:
            return
        with self._lock:
            u = tuple(s.u_goal_rad() for s in self.servos)
            speed = tuple(s.speed_ticks_s() * 2 * np.pi / TICKS_PER_REV for s in self.servos)
            if (u, speed) == self._last_body_command:
                return
            self._last_body_command = (u, speed)
            self._body_queue.put((np.array(u), self.body.now(), np.array(speed)))

    def _drive_body(self) -> None:
        while (item := self._body_queue.get()) is not None:
            u, t_s, speed = item
            try:
                self.body.command(u, t_s=t_s, profile_velocity_rad_s=speed)
            except Exception as err:  # noqa: BLE001 - kept for the test that drives the bus
                self.body_error = err
            finally:
                self._body_queue.task_done()

    def wait_body(self, timeout_s: float = 10.0) -> None:
        """Block until the body has been given every queued command (for tests).

        Parameters
        ----------
        timeout_s : float
            Longest wait (s, wall clock); returns then even with commands still queued.
        """
        deadline = time.monotonic() + timeout_s
        while self._body_queue.unfinished_tasks and time.monotonic() < deadline:
            time.sleep(0.005)

    def _take_fault(self, s: EmulatedServo, kind: str) -> bool:
        if s.fault != kind:
            return False
        if s.fault_count is not None:
            s.fault_count -= 1
            if s.fault_count <= 0:
                s.fault = None
        return True

    def _reply(self, s: EmulatedServo, error: int, data: bytes = b"", *, kind: str = "") -> bytes | None:
        level = s.get("status_return_level")
        if (kind == "read" and level < 1) or (kind == "write" and level < 2):
            return None
        if self._take_fault(s, "silent"):  # (``count`` replies, or all of them)
            return None
        bad = self._take_fault(s, "bad_crc")
        return p2.status(s.dxl_id, error, data, corrupt_crc=bad)

    def _handle(self, pkt: p2.Packet) -> list[bytes]:
        self.packets += 1
        t = self.now()
        if self._t_last_packet is not None:
            self.max_packet_gap_s = max(self.max_packet_gap_s, t - self._t_last_packet)
        self._t_last_packet = t
        baud = self._port_baud()
        hearing = [s for s in self.servos if s.fault != "disconnected" and (baud is None or baud == s.baud_rate)]
        broadcast = pkt.dxl_id == p2.BROADCAST_ID
        targets = hearing if broadcast else [s for s in hearing if s.dxl_id == pkt.dxl_id]
        if not pkt.crc_ok and broadcast:
            return []
        noisy = [s for s in targets if self._take_fault(s, "crc_error")]
        if not pkt.crc_ok or (noisy and not broadcast):
            return [r for s in targets if (r := self._reply(s, p2.ERR_CRC | s.alert))]
        targets = [s for s in targets if s not in noisy]  # a broadcast still reaches the others
        addressed = targets
        if broadcast and pkt.instruction in (p2.SYNC_WRITE, p2.SYNC_READ) and len(pkt.params) >= 4:
            n = pkt.params[2] | (pkt.params[3] << 8)
            ids = pkt.params[4 :: n + 1] if pkt.instruction == p2.SYNC_WRITE else pkt.params[4:]
            addressed = [s for s in targets if s.dxl_id in set(ids)]
        for s in addressed:
            s.heard(t)
        out: list[bytes | None] = []
        prm = pkt.params
        word = lambda i: prm[i] | (prm[i + 1] << 8)  # noqa: E731
        if pkt.instruction == p2.PING:
            for s in sorted(targets, key=lambda s: s.dxl_id):
                fw = s.get("firmware_version")
                out.append(self._reply(s, s.alert, struct.pack("<HB", s.get("model_number"), fw)))
        elif pkt.instruction == p2.READ and not broadcast:
            for s in targets:
                if len(prm) != 4:
                    out.append(self._reply(s, p2.ERR_DATA_LENGTH | s.alert, kind="read"))
                else:
                    err, data = s.read(word(0), word(2), t)
                    out.append(self._reply(s, err, data, kind="read"))
        elif pkt.instruction == p2.WRITE:
            for s in targets:
                err = s.write(word(0), prm[2:], t) if len(prm) > 2 else p2.ERR_DATA_LENGTH | s.alert
                if not broadcast:
                    out.append(self._reply(s, err, kind="write"))
        elif pkt.instruction == p2.SYNC_WRITE and broadcast and len(prm) >= 4:
            addr, n = word(0), word(2)
            for i in range(4, len(prm) - n, n + 1):
                for s in targets:
                    if s.dxl_id == prm[i]:
                        s.write(addr, prm[i + 1 : i + 1 + n], t)
        elif pkt.instruction == p2.SYNC_READ and broadcast and len(prm) >= 4:
            addr, n = word(0), word(2)
            for dxl_id in prm[4:]:
                s = next((s for s in targets if s.dxl_id == dxl_id), None)
                reply = None if s is None else self._reply(s, *s.read(addr, n, t), kind="read")
                if reply is None:
                    break  # the servos after a missing answer wait for it in vain
                out.append(reply)
        elif pkt.instruction == p2.REBOOT and not broadcast:
            for s in targets:
                out.append(self._reply(s, 0))
                s.power_up(t)
        elif not broadcast:
            out.extend(self._reply(s, p2.ERR_INSTRUCTION | s.alert) for s in targets)
        return [r for r in out if r is not None]
