"""The whole hardware set-up emulated: servo bus + NatNet server around one body.

``EmulatedBench(robot, body)`` starts an ``EmulatedXM430Bus`` on a pty and a
``NatNetServerEmulator`` on loopback, both driving the same ``LiveBody``, and writes a
hardware rig configuration (``write_config``) that points at them, so that
``HardwareRig.from_config`` -- the real SDK and the real NatNet client -- runs against
the emulated robot. The servos' physical truth (``specs``) is deliberately untidy:
arbitrary zero ticks, one mirrored motor, one zero a turn away from where the servo
reports it at power-up; the configuration carries the matching calibration. With
``virtual_time=True`` everything runs on one ``VirtualClock``, which moves a frame period
per frame the rig reads (``rig_options()`` gives the rig that clock).
"""

from __future__ import annotations

import json
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from lab.description import RobotDescription
from lab.errors import InputError
from lab.rig.base import Body
from lab.rig.emulators.bodies import KinematicBody, LiveBody
from lab.rig.emulators.clock import VirtualClock
from lab.rig.emulators.mocap_scene import MocapScene
from lab.rig.emulators.natnet_server import NatNetServerEmulator
from lab.rig.emulators.xm430 import EmulatedXM430Bus, ServoSpec


def default_specs(n_motors: int) -> list[ServoSpec]:
    """IDs 1..n; zero ticks 1000, 5000 (reported a turn lower at power-up), 3100, ...;
    every second motor mirrored.

    Parameters
    ----------
    n_motors : int
        Number of servos.

    Returns
    -------
    list of ServoSpec
        One physical truth per servo, ID ``i + 1`` for motor ``i``.
    """
    zeros = [1000, 5000, 3100, 700, 2500, 3900]
    return [
        ServoSpec(i + 1, zero_tick=zeros[i % len(zeros)] + 4096 * (i // len(zeros)), direction=1 if i % 2 == 0 else -1)
        for i in range(n_motors)
    ]


def kinematic_body_for(robot: RobotDescription, gain_m_per_rad: float = 0.02) -> KinematicBody:
    """A ``KinematicBody`` for ``robot``: pulling a cable moves the tip toward that cable's
    side (its first via point's direction from the axis) and slightly back along x.

    Parameters
    ----------
    robot : RobotDescription
        The robot (its cables' via points and the tip marker's rest position).
    gain_m_per_rad : float
        Tip displacement per motor angle (m/rad).

    Returns
    -------
    KinematicBody
        Tip at rest at ``robot.p_tip_marker_W``, Jacobian ``J_W`` of shape (3, n_cables) m/rad.
    """
    cols = []
    for cable in robot.cables:
        yz = cable.via_points_m[0, 1:]
        yz = yz / (np.linalg.norm(yz) or 1.0)
        cols.append(gain_m_per_rad * np.array([-0.2, yz[0], yz[1]]))
    return KinematicBody(robot.p_tip_marker_W, np.column_stack(cols))


def _toml(value) -> str:
    return json.dumps(value) if not isinstance(value, bool) else str(value).lower()


class EmulatedBench:
    """Emulated servos and motion capture around ``body`` (a ``Body``); context manager.

    Parameters
    ----------
    robot : RobotDescription
        The robot the bench stands in for (one servo per cable).
    body : Body, optional
        The arm both emulators drive; a :func:`kinematic_body_for` the robot when omitted.
    specs : list of ServoSpec, optional
        The servos' physical truth (IDs, zero ticks, directions), one per cable;
        :func:`default_specs` when omitted.
    scene : MocapScene
        The motion-capture scene (marker names, base markers, length unit).
    natnet_version : tuple of int
        NatNet protocol version the server speaks, e.g. (3, 1).
    multicast : bool
        Stream frames by multicast (True) or unicast (False).
    noise_m : float
        Gaussian noise per axis on the streamed marker positions (m).
    frame_rate_hz : float
        Motion-capture frame rate (Hz).
    seed : int
        Seed of the marker noise.
    virtual_time : bool
        False runs on the wall clock; True on ``self.clock``, a ``VirtualClock`` that the
        NatNet server advances by one frame period per frame the rig wants, once the body
        has taken every command of the current time.
    """

    def __init__(
        self,
        robot: RobotDescription,
        body: Body | None = None,
        *,
        specs=None,
        scene: MocapScene = MocapScene(),
        natnet_version=(3, 1),
        multicast: bool = False,
        noise_m: float = 0.0,
        frame_rate_hz: float = 120.0,
        seed: int = 0,
        virtual_time: bool = False,
    ):
        self.robot = robot
        self.clock = VirtualClock() if virtual_time else None
        clock = time.monotonic if self.clock is None else self.clock
        self.body = body if body is not None else kinematic_body_for(robot)
        self.live = LiveBody(self.body, clock=clock)
        self.specs = list(specs) if specs is not None else default_specs(robot.n_cables)
        if len(self.specs) != robot.n_cables:
            raise InputError(f"{len(self.specs)} servo specs for {robot.n_cables} cables")
        self.scene = scene
        self.bus = EmulatedXM430Bus(self.specs, body=self.live, clock=clock)
        try:
            self.mocap = NatNetServerEmulator(
                self.live.p_tip_W,
                scene,
                version=natnet_version,
                multicast=multicast,
                noise_m=noise_m,
                frame_rate_hz=frame_rate_hz,
                seed=seed,
                clock=self.clock,
                before_frame=self.bus.wait_body,
            )
        except BaseException:
            self.bus.stop()
            raise

    def start(self) -> EmulatedBench:
        """Start the servo bus and the NatNet server.

        Returns
        -------
        EmulatedBench
            ``self``, serving.
        """
        self.bus.start()
        self.mocap.start()
        return self

    def stop(self) -> None:
        """Stop the NatNet server and the servo bus."""
        try:
            self.mocap.stop()
        finally:
            self.bus.stop()

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.stop()
        return False

    def rig_options(self) -> dict:
        """Keyword arguments that put a ``HardwareRig`` on this bench's clock.

        The emulated bus answers from a thread of this process, so the driver's reply timeout
        is measured on the waiting thread's CPU time (``time.thread_time``): a loaded
        machine that starves the process is not a lost status packet, and a silent servo
        still times out after the driver has polled for the timeout.

        Returns
        -------
        dict
            ``reply_timer``; on virtual time also ``clock`` (the :class:`VirtualClock`) and
            ``frame_wanted`` (the wish for each frame the rig waits for).
        """
        options = {"reply_timer": time.thread_time}
        if self.clock is None:
            return options
        return options | {"clock": self.clock, "frame_wanted": self.clock.want_frame}

    def config_text(self, servos: dict | None = None, mocap: dict | None = None) -> str:
        """TOML of a hardware configuration for this bench; ``servos``/``mocap`` override
        fields of those tables (for tests of bad settings). The mocap frame timeout is 2 s
        on the wall clock (the server shares a possibly loaded machine with the rig: its
        frames came up to 0.07 s apart with two CPU-bound processes beside it on 2 cores),
        10 s on virtual time (where it only detects a dead server).

        Parameters
        ----------
        servos : dict, optional
            Field -> value overriding the ``[servos]`` table.
        mocap : dict, optional
            Field -> value overriding the ``[mocap]`` table.

        Returns
        -------
        str
            The configuration's TOML text (motor calibration matching ``specs``).
        """
        s = {
            "port": self.bus.port,
            "baud_rate": self.specs[0].baud_rate,
            "profile_velocity_rad_s": 3.0,
            "latency_timer_ms": 100.0,
            "poll_interval_s": 0.05,
        } | (servos or {})
        m = {
            "server_address": self.mocap.host,
            "local_address": self.mocap.host,
            "transmission": "multicast" if self.mocap.multicast else "unicast",
            "multicast_address": self.mocap.multicast_address,
            "command_port": self.mocap.command_port,
            "data_port": self.mocap.data_port,
            "length_unit": "mm" if self.scene.length_unit_m == 1e-3 else "m",
            "frame_rate_hz": self.mocap.frame_rate_hz,
            "connect_timeout_s": 3.0,
            "frame_timeout_s": 2.0 if self.clock is None else 10.0,
            "max_occlusion_s": 0.5,
            "calibration_frames": 12,
            "marker_set": self.scene.marker_set,
        } | (mocap or {})
        lines = ["format_version = 1", "", "[servos]"] + [f"{k} = {_toml(v)}" for k, v in s.items()]
        for spec, cable in zip(self.specs, self.robot.cables):
            lines += [
                "",
                "[[servos.motor]]",
                f"cable = {_toml(cable.name)}",
                f"id = {spec.dxl_id}",
                f"direction = {spec.direction}",
                f"zero_offset_ticks = {spec.zero_tick}",
            ]
        lines += ["", "[mocap]"] + [f"{k} = {_toml(v)}" for k, v in m.items()]
        lines += ["", "[mocap.tip]", f"marker = {_toml(self.scene.tip_marker)}"]
        for name, p in zip(self.scene.base_markers, self.scene.base_positions_W_m):
            lines += [
                "",
                "[[mocap.base_markers]]",
                f"marker = {_toml(name)}",
                f"position_W_m = {_toml([float(c) for c in p])}",
            ]
        return "\n".join(lines) + "\n"

    def write_config(self, path: str | Path, **overrides) -> Path:
        """Write ``config_text(**overrides)`` to ``path`` atomically.

        Parameters
        ----------
        path : str or Path
            The configuration file to write.
        **overrides
            ``servos``/``mocap``: as for :meth:`config_text`.

        Returns
        -------
        Path
            ``path``.
        """
        path = Path(path)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
        try:
            with os.fdopen(fd, "w") as f:
                f.write(self.config_text(**overrides))
            os.replace(tmp, path)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
        return path
