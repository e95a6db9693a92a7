"""Capture on a rig (above the rigs of stage 9a): the paper's protocol, journaled, or the predictive one.

On any :class:`~lab.rig.Rig`, :func:`measure` (:mod:`.protocol`) takes one sample with a
:class:`Protocol` (reset, move, wait until the :class:`SettleDetector` says settled, record)
and :func:`capture` (:mod:`.session`) runs it over a list of commands into an append-only
:class:`Journal` (settings: :class:`CaptureSpec`, :class:`ProtocolSpec`), or the predictive
protocol (:class:`PredictiveSampler`: the settled tip predicted by a Kalman filter,
:class:`TipFilter`, of the learned relaxation of :mod:`lab.dynamics`, from readings kept by
:class:`StreamRecorder`). :class:`CapturedDataset` turns a capture into a dataset;
:mod:`.active` captures the active designs' batches and :mod:`.dynamics_probe` the steps
that the relaxation is fitted to. Capture works through the rig interface only: it never
imports the as-built robots (:mod:`lab.asbuilt`). The design: ``docs/design/rig.md``.
"""

from __future__ import annotations

from lab.capture.dataset import CapturedDataset
from lab.capture.journal import Journal, JournalError
from lab.capture.predictive import PredictiveSampler
from lab.capture.protocol import PROTOCOLS, Protocol, Sample, SettleDetector, measure
from lab.capture.recorder import StreamRecorder
from lab.capture.session import Capture, capture
from lab.capture.spec import CaptureSpec, ProtocolSpec
from lab.capture.tip_filter import TipFilter

__all__ = [
    "PROTOCOLS",
    "PredictiveSampler",
    "StreamRecorder",
    "TipFilter",
    "Capture",
    "CaptureSpec",
    "CapturedDataset",
    "ProtocolSpec",
    "Protocol",
    "Sample",
    "SettleDetector",
    "capture",
    "measure",
    "Journal",
    "JournalError",
]
