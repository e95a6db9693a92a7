"""Stage 9a: rigs -- the robot behind one interface (:class:`Rig`), simulated, emulated or real.

:class:`RigSpec` (:mod:`.spec`) is the ``--rig`` option -- ``sim`` (the nominal FEM,
:class:`SimRig`), ``twin``, ``twin:DEFECTS.toml``, ``twin:random:SEED`` or ``twin:foam:SEED``
(an emulated as-built robot: :class:`TwinRig`, :class:`FamilyTwinRig`, :class:`FoamTwinRig`),
``hardware:CONFIG.toml``
(Dynamixel servos and OptiTrack: :mod:`.hardware`) -- and :func:`make_rig` (:mod:`.factory`)
is the one place that builds the rig it names. On any rig, :func:`capture` (``lab/rig/capture.py``)
runs the paper's capture protocol (settings: :class:`CaptureSpec`, :class:`ProtocolSpec`)
into an append-only :class:`Journal`, or the predictive one
(:class:`PredictiveSampler`: the settled tip predicted by a Kalman filter, :class:`TipFilter`,
of the learned relaxation of :mod:`lab.dynamics`, from readings kept by
:class:`StreamRecorder`). Emulators of the servo bus and the NatNet server for tests and dry
runs are in :mod:`lab.rig.emulators`; the design and its measured history are in
``docs/design/rig.md``.
"""

from __future__ import annotations

from lab.rig.asbuilt import Defects, DefectsError, default_defects_path, load_defects, parse_defects
from lab.rig.base import Body, MocapError, MocapFrame, Rig, RigError, ServoError
from lab.rig.capture import Capture, capture, journal_columns
from lab.rig.capture_dataset import CapturedDataset
from lab.rig.capture_spec import CaptureSpec, ProtocolSpec
from lab.rig.factory import as_built_body, make_rig
from lab.rig.family import FamilyTwinRig, FoamTwinRig, random_defects, random_defects_toml, write_random_defects
from lab.rig.foam_family import foam_defects, foam_defects_toml, write_foam_defects
from lab.rig.journal import Journal, JournalError
from lab.rig.predictive import PredictiveSampler
from lab.rig.protocol import PROTOCOLS, Protocol, Sample, SettleDetector, measure
from lab.rig.recorder import StreamRecorder
from lab.rig.sim import SimRig
from lab.rig.spec import RIG_FORMS, RIG_KINDS, RigSpec
from lab.rig.tip_filter import TipFilter
from lab.rig.twin import AsBuiltBody, MocapModel, TwinRig

__all__ = [
    "PROTOCOLS",
    "PredictiveSampler",
    "StreamRecorder",
    "TipFilter",
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
    "Capture",
    "CaptureSpec",
    "CapturedDataset",
    "ProtocolSpec",
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
    "DefectsError",
    "default_defects_path",
    "load_defects",
    "parse_defects",
    "FamilyTwinRig",
    "random_defects",
    "random_defects_toml",
    "write_random_defects",
    "FoamTwinRig",
    "foam_defects",
    "foam_defects_toml",
    "write_foam_defects",
]
