"""``HardwareRig``: Dynamixel XM430 servos pulling the cables, OptiTrack watching the tip.

``HardwareRig.from_config("RIG.toml", robot)`` (or ``make_rig("hardware:RIG.toml", robot)``)
connects motion capture first (nothing moves until it works: connection, marker names,
frame W from the base markers), then the servo bus (ping, extended position mode,
profile velocity, start-up angle check), then enables torque holding the present pose.

* ``send(u)``: validated by the robot description, sync-written as goal positions;
  the present positions are read back at once, so a dead or overloaded servo is caught
  on the command that meets it;
* ``next_frame()``: the next NatNet frame, tip in W (NaN while occluded), stamped on
  the rig clock ``now()`` (host monotonic time since the rig was made, s); servos are
  polled every ``servos.poll_interval_s`` of frames read, so an overload is caught while
  the caller only watches the tip;
* any error on the way (``ServoError``, ``MocapError``, a serial failure, even
  KeyboardInterrupt) closes the rig -- torque off on every servo, confirmed by read-back
  -- before it propagates; ``failure`` keeps the reason. ``close()`` is idempotent and
  also runs at interpreter exit. Not made safe: a process killed by a signal (SIGTERM,
  SIGKILL: no Python cleanup runs) or a lost USB link, which leave the servos holding
  their last goal; cut servo power then.
"""

from __future__ import annotations

import atexit
import time
from pathlib import Path

import numpy as np

from lab.description import RobotDescription
from lab.rig.base import MocapError, MocapFrame, Rig, RigError
from lab.rig.dynamixel import X_SERIES_MODELS, XM430Bus
from lab.rig.hardware_config import HardwareConfig, load_hardware_config
from lab.rig.optitrack import OptiTrackStream


class HardwareRig(Rig):
    """The physical robot behind the rig interface (wall clock, real servos and mocap)."""

    kind = "hardware"

    def __init__(self, robot: RobotDescription, config: HardwareConfig):
        super().__init__(robot, config.frame_rate_hz)
        self.config = config
        self.failure: str | None = None
        self.torque_unconfirmed: list[int] = []
        self._t0 = time.monotonic()
        self._bus: XM430Bus | None = None
        self._mocap: OptiTrackStream | None = None
        atexit.register(self.close)
        try:
            self._mocap = OptiTrackStream(config.natnet, clock=self.now)
            self._bus = XM430Bus(
                config.port,
                config.baud_rate,
                config.servos,
                profile_velocity_rad_s=config.profile_velocity_rad_s,
                u_max_rad=robot.u_max_rad,
                start_margin_rad=config.start_margin_rad,
                latency_timer_ms=config.latency_timer_ms,
                bus_watchdog_ms=config.bus_watchdog_ms,
            )
            self._bus.torque_on()
            self._poll()
        except BaseException as err:
            self._stop(err)
            raise

    @classmethod
    def from_config(cls, path: str | Path, robot: RobotDescription) -> HardwareRig:
        """Rig from a TOML file (``lab/rigs/hardware-example.toml`` documents the format)."""
        return cls(robot, load_hardware_config(path, robot))

    # --- the rig interface ------------------------------------------------------------
    def now(self) -> float:
        return time.monotonic() - self._t0

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
