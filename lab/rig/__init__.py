"""Stage 9a: rigs -- the robot behind one interface (:class:`Rig`), simulated, emulated or real.

:class:`RigSpec` (:mod:`.spec`) is the ``--rig`` option -- ``sim`` (the nominal FEM,
:class:`SimRig`), ``twin``, ``twin:DEFECTS.toml``, ``twin:random:SEED``, ``twin:foam:SEED`` or
``twin:pneumatic:SEED`` (an emulated as-built robot, :class:`TwinRig`; a member of a family
of them, :class:`FamilyTwinRig`; pressure regulators instead of servos for a robot with
chambers, :class:`PneumaticBody`), ``hardware:CONFIG.toml`` (Dynamixel servos and OptiTrack:
:mod:`.hardware`) -- and :func:`make_rig` (:mod:`.factory`) is the one place that builds
the rig it names. The as-built robots the twins emulate (defects files, the families that
draw them) are :mod:`lab.asbuilt`, below this package; capture on a rig (the protocol,
the journal, the predictive sampler) is :mod:`lab.capture`, above it. Emulators of the
servo bus and the NatNet server for tests and dry runs are in :mod:`lab.rig.emulators`;
the design and its measured history are in ``docs/design/rig.md``.
"""

from __future__ import annotations

from lab.rig.base import Body, MocapError, MocapFrame, Rig, RigError, ServoError
from lab.rig.factory import as_built_body, make_rig
from lab.rig.pneumatic_body import PneumaticBody
from lab.rig.sim import SimRig
from lab.rig.spec import RIG_FORMS, RIG_KINDS, RigSpec
from lab.rig.twin import AsBuiltBody, FamilyTwinRig, TwinRig, emulated_body

__all__ = [
    "make_rig",
    "as_built_body",
    "RigSpec",
    "RIG_KINDS",
    "RIG_FORMS",
    "Rig",
    "Body",
    "MocapFrame",
    "RigError",
    "ServoError",
    "MocapError",
    "SimRig",
    "TwinRig",
    "FamilyTwinRig",
    "AsBuiltBody",
    "PneumaticBody",
    "emulated_body",
]
