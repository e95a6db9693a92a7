"""Emulated hardware for testing the hardware rig without a robot.

* ``EmulatedXM430Bus`` (``xm430.py``): Dynamixel XM430 servos speaking Protocol 2.0 on
  a pseudo-terminal, for the real ``dynamixel_sdk``; fault injection.
* ``NatNetServerEmulator`` (``natnet_server.py``): an OptiTrack NatNet server on
  loopback UDP, for the real ``natnet`` client; occlusion and a vanishing server.
* ``LiveBody``/``KinematicBody`` (``bodies.py``): a ``Body`` shared by both on one clock,
  and a simple one.
* ``VirtualClock`` (``clock.py``): time that moves one frame period per frame the rig
  wants, so that tests do not depend on how threads are scheduled.
* ``EmulatedBench`` (``bench.py``): all of it together plus a matching rig config;
  ``python -m lab.rig.emulators --config-out RIG.toml`` serves it until interrupted.
"""

from lab.rig.emulators.bench import EmulatedBench
from lab.rig.emulators.bodies import KinematicBody, LiveBody
from lab.rig.emulators.clock import VirtualClock
from lab.rig.emulators.mocap_scene import MocapScene
from lab.rig.emulators.natnet_server import NatNetServerEmulator
from lab.rig.emulators.xm430 import FAULTS, EmulatedXM430Bus, ServoSpec

__all__ = [
    "EmulatedBench",
    "EmulatedXM430Bus",
    "FAULTS",
    "KinematicBody",
    "LiveBody",
    "MocapScene",
    "NatNetServerEmulator",
    "ServoSpec",
    "VirtualClock",
]
