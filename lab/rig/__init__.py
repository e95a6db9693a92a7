"""Stage 9a: rigs -- the robot behind one interface (:class:`Rig`), simulated, emulated or real.

``make_rig(spec, robot)`` turns the ``--rig`` option of the command line into a rig:

* ``"sim"``               nominal quasi-static FEM (:class:`SimRig`, :mod:`.sim`)
* ``"twin"``              emulated as-built robot with the shipped default defects
                          (:class:`TwinRig`, :mod:`.twin` and :mod:`.asbuilt`)
* ``"twin:DEFECTS.toml"`` emulated as-built robot with the user's defect file
* ``"twin:random:SEED"``  member SEED (an integer >= 0) of a family of emulated as-built
                          robots with random defects (:class:`FamilyTwinRig`, :mod:`.family`)
* ``"hardware:RIG.toml"`` Dynamixel servos + OptiTrack, configured by the file
                          (:class:`HardwareRig`: :mod:`.hardware`, :mod:`.dynamixel`,
                          :mod:`.optitrack`, :mod:`.hardware_config`)

On any rig, :func:`capture` (:mod:`.capture`) runs the paper's capture protocol
(settle test, hysteresis reset) into an append-only :class:`Journal` (:mod:`.journal`), or
the predictive one (:class:`PredictiveSampler`, :mod:`.predictive`: the settled tip
predicted by a Kalman filter of the learned relaxation, :mod:`.tip_filter`, from a stream
of readings recorded by :class:`StreamRecorder`, :mod:`.recorder`).
Emulators of the servo bus and the NatNet server for tests and dry runs are in
:mod:`lab.rig.emulators`.
"""

from __future__ import annotations

from lab.description import RobotDescription
from lab.errors import InputError
from lab.rig.asbuilt import Defects, default_defects_path, load_defects, parse_defects
from lab.rig.base import Body, MocapError, MocapFrame, Rig, RigError, ServoError
from lab.rig.capture import Capture, capture, journal_columns
from lab.rig.family import FamilyTwinRig, random_defects, random_defects_toml, write_random_defects
from lab.rig.journal import Journal, JournalError
from lab.rig.predictive import PredictiveSampler
from lab.rig.protocol import PROTOCOLS, Protocol, Sample, SettleDetector, measure
from lab.rig.recorder import StreamRecorder
from lab.rig.sim import SimRig
from lab.rig.tip_filter import TipFilter
from lab.rig.twin import AsBuiltBody, MocapModel, TwinRig

__all__ = [
    "PROTOCOLS",
    "PredictiveSampler",
    "StreamRecorder",
    "TipFilter",
    "make_rig",
    "Rig",
    "Body",
    "MocapFrame",
    "RigError",
    "ServoError",
    "MocapError",
    "Capture",
    "Protocol",
    "Sample",
    "SettleDetector",
    "capture",
    "journal_columns",
    "measure",
    "Journal",
    "JournalError",
    "SimRig",
    "TwinRig",
    "AsBuiltBody",
    "MocapModel",
    "Defects",
    "default_defects_path",
    "load_defects",
    "parse_defects",
    "FamilyTwinRig",
    "random_defects",
    "random_defects_toml",
    "write_random_defects",
]


def make_rig(spec: str, robot: RobotDescription, *, seed: int = 0) -> Rig:
    """Rig for the command-line spec ``sim | twin[:DEFECTS.toml | :random:SEED] | hardware:CONFIG.toml``.

    ``seed`` makes the emulated robot's noise reproducible (``twin:random:SEED`` picks the
    robot of the family; ``seed`` still only the noise). Raises :class:`lab.errors.InputError`
    (a ValueError) naming the problem for an unknown kind or a missing file argument.
    """
    kind, _, arg = str(spec).partition(":")
    if kind == "sim":
        if arg:
            raise InputError(f"rig 'sim' takes no argument, got {spec!r}")
        from lab.rig.sim import SimRig

        return SimRig(robot)
    if kind == "twin":
        if arg == "random" or arg.startswith("random:"):
            from lab.rig.family import FamilyTwinRig, parse_robot_seed

            robot_seed = arg.partition(":")[2]
            if not robot_seed:
                raise InputError(f"rig {spec!r} needs the robot's seed: --rig twin:random:SEED (e.g. twin:random:3)")
            return FamilyTwinRig(robot, parse_robot_seed(robot_seed, spec), seed=seed)
        from lab.rig.twin import TwinRig

        return TwinRig(robot, defects=arg or None, seed=seed)
    if kind == "hardware":
        if not arg:
            raise InputError("rig 'hardware' needs a configuration file: --rig hardware:RIG.toml")
        from lab.rig.hardware import HardwareRig

        return HardwareRig.from_config(arg, robot)
    raise InputError(
        f"unknown rig {spec!r}: expected sim, twin[:DEFECTS.toml], twin:random:SEED or hardware:CONFIG.toml"
    )
