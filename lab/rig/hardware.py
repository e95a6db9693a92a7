"""``HardwareRig``: Dynamixel XM430 servos pulling the cables, OptiTrack watching the tip.

``HardwareRig.from_config("RIG.toml", robot)`` (or ``make_rig("hardware:RIG.toml", robot)``)
connects motion capture first (nothing moves until it works), then the servo bus, then
enables torque holding the present pose. ``send(u)`` is validated by the robot
description, sync-written and read back at once; ``next_frame()`` is the next NatNet
frame, tip in W, stamped on the rig clock (host monotonic time, s; the emulators' virtual
clock in tests), with the servos polled every ``servos.poll_interval_s``. Any error on the
way (even KeyboardInterrupt) closes the rig -- torque off on every servo, confirmed by
read-back -- before it propagates; ``close()`` is idempotent and also runs at interpreter
exit. Not made safe: a process killed by a signal (the servos' Bus Watchdog, when on, stops
them) or a lost USB link (cut servo power then). Details: ``docs/design/rig.md``.
"""

from __future__ import annotations

import atexit
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from lab.description import RobotDescription
from lab.rig.base import MocapError, MocapFrame, Rig, RigError
from lab.rig.dynamixel import X_SERIES_MODELS, XM430Bus
from lab.rig.hardware_config import HardwareConfig, load_hardware_config
from lab.rig.optitrack import OptiTrackStream


class HardwareRig(Rig):
    """The physical robot behind the rig interface (wall clock, real servos and mocap).

    ``clock`` (s) is the rig clock's source; ``frame_wanted`` is called before each wait
    for a frame; ``reply_timer`` (s) is what the servos' reply timeout is measured on. All
    three are for emulated hardware (``EmulatedBench.rig_options()``); on real hardware
    leave them out.
    """

    kind = "hardware"

    def __init__(
        self,
        robot: RobotDescription,
        config: HardwareConfig,
        *,
        clock: Callable[[], float] = time.monotonic,
        frame_wanted: Callable[[], None] | None = None,
        reply_timer: Callable[[], float] | None = None,
    ):
        super().__init__(robot, config.frame_rate_hz)
        self.config = config
        self.failure: str | None = None
        self.torque_unconfirmed: list[int] = []
        self._clock = clock
        self._t0 = clock()
        self._bus: XM430Bus | None = None
        self._mocap: OptiTrackStream | None = None
        atexit.register(self.close)
        try:
            self._mocap = OptiTrackStream(config.natnet, clock=self.now, frame_wanted=frame_wanted)
            self._bus = XM430Bus(
                config.port,
                config.baud_rate,
                config.servos,
                profile_velocity_rad_s=config.profile_velocity_rad_s,
                u_max_rad=robot.u_max_rad,
                start_margin_rad=config.start_margin_rad,
                latency_timer_ms=config.latency_timer_ms,
                bus_watchdog_ms=config.bus_watchdog_ms,
                clock=self.now,
                reply_timer=reply_timer,
            )
            self._bus.torque_on()
            self._poll()
        except BaseException as err:
            self._stop(err)
            raise

    @classmethod
    def from_config(cls, path: str | Path, robot: RobotDescription, **options) -> HardwareRig:
        """Rig from a TOML file (``lab/rigs/hardware-example.toml`` documents the format);
        ``options``: ``clock``/``frame_wanted``/``reply_timer`` as for the constructor."""
        return cls(robot, load_hardware_config(path, robot), **options)

    # --- the rig interface ------------------------------------------------------------
    def now(self) -> float:
        return self._clock() - self._t0

    def _send(self, u_motor: np.ndarray) -> None:
        self._guard(lambda: (self._bus.write_goal_u(u_motor), self._poll()))

    def present_u(self) -> np.ndarray:
        return self._guard(self._poll)

    def next_frame(self) -> MocapFrame:
        frame = self._guard(self._mocap.next_frame)
        if self.now() - self._t_poll >= self.config.poll_interval_s:
            self._guard(self._poll)
        return frame

    # --- safety -----------------------------------------------------------------------
    def _poll(self) -> np.ndarray:
        self._u_present = self._bus.read_present_u()
        self._t_poll = self.now()
        return self._u_present.copy()

    def _guard(self, operation):
        if self._closed:
            raise RigError(f"hardware rig is closed{': ' + self.failure if self.failure else ''}")
        try:
            return operation()
        except MocapError as err:
            self._stop(err)
            raise MocapError(f"{err} [hardware rig stopped: {self._torque_note()}]") from None
        except BaseException as err:
            self._stop(err)
            raise

    def _stop(self, err: BaseException) -> None:
        self.failure = f"{type(err).__name__}: {err}"
        self.close()

    def _torque_note(self) -> str:
        if self.torque_unconfirmed:
            return f"torque off NOT confirmed for servo IDs {self.torque_unconfirmed}: switch off servo power"
        return "torque off"

    def _close(self) -> None:
        atexit.unregister(self.close)
        if self._bus is not None:
            self.torque_unconfirmed = self._bus.close()
        if self._mocap is not None:
            self._mocap.close()

    def describe(self) -> dict:
        c, bus, mocap = self.config, self._bus, self._mocap
        out = {
            **super().describe(),
            "config": c.source,
            "serial_port": c.port,
            "baud_rate": c.baud_rate,
            "servo_ids": [s.dxl_id for s in c.servos],
            "directions": [s.direction for s in c.servos],
            "profile_velocity_rad_s": c.profile_velocity_rad_s,
            "mocap_server": f"{c.natnet.server_address}:{c.natnet.command_port}",
            "mocap_transmission": "multicast" if c.natnet.multicast else "unicast",
            "failure": self.failure,
        }
        if bus is not None:
            out["servo_models"] = [X_SERIES_MODELS.get(bus.model_numbers.get(i), "?") for i in bus.ids]
            out["zero_ticks"] = [int(z) for z in bus.zero_ticks]
        if mocap is not None and hasattr(mocap, "R_WM"):
            out |= {
                "natnet_version": str(mocap.server_info.nat_net_protocol_version),
                "R_WM": mocap.R_WM.tolist(),
                "t_WM_m": mocap.t_WM_m.tolist(),
                "base_fit_rms_m": mocap.base_fit_rms_m,
                "frames_received": mocap.frames_received,
                "frames_dropped": mocap.frames_dropped,
                "measured_frame_rate_hz": None if np.isnan(rate := mocap.measured_rate_hz) else rate,
            }
        return out
