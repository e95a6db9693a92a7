"""Rigs: the robot behind one interface (``Rig``), simulated, emulated or real.

``make_rig(spec, robot)`` turns the ``--rig`` option of the command line into a rig:

* ``"sim"``               nominal quasi-static FEM (``SimRig``)
* ``"twin"``              emulated as-built robot with the shipped default defects
* ``"twin:DEFECTS.toml"`` emulated as-built robot with the user's defect file
* ``"hardware:RIG.toml"`` Dynamixel servos + OptiTrack, configured by the file
"""
from __future__ import annotations

from ..description import RobotDescription
from .base import MocapError, MocapFrame, Rig, RigError, ServoError

__all__ = ["make_rig", "Rig", "MocapFrame", "RigError", "ServoError", "MocapError"]


def make_rig(spec: str, robot: RobotDescription, *, seed: int = 0) -> Rig:
    """Rig for the command-line spec ``sim | twin[:DEFECTS.toml] | hardware:CONFIG.toml``.

    ``seed`` makes the emulated robot's noise reproducible. Raises ValueError naming the
    problem for an unknown kind or a missing file argument.
    """
    kind, _, arg = str(spec).partition(":")
    if kind == "sim":
        if arg:
            raise ValueError(f"rig 'sim' takes no argument, got {spec!r}")
        from .sim import SimRig
        return SimRig(robot)
    if kind == "twin":
        from .twin import TwinRig
        return TwinRig(robot, defects=arg or None, seed=seed)
    if kind == "hardware":
        if not arg:
            raise ValueError("rig 'hardware' needs a configuration file: --rig hardware:RIG.toml")
        from .hardware import HardwareRig
        return HardwareRig.from_config(arg, robot)
    raise ValueError(f"unknown rig {spec!r}: expected sim, twin[:DEFECTS.toml] or hardware:CONFIG.toml")
