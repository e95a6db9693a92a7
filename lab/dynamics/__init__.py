"""Stage 6b: learned models of the foam in time, on top of the quasi-static model (stage 6).

A viscoelastic arm creeps toward the equilibrium the quasi-static model predicts.
:class:`Relaxation` (:mod:`.relaxation`) is that creep as ``K`` first-order modes, saved as
``.npz`` (kind ``lab.dynamics``, :func:`load_relaxation`); :mod:`.relaxation_fit` fits it to
step responses (:func:`~lab.dynamics.relaxation_fit.fit_exponentials`) or to a recorded :class:`Stream` of commands
(:class:`Segment`) and motion-capture readings (:func:`fit_stream`). The rig stage runs it
as a Kalman filter during capture and the tracking stage inverts it into a feed-forward command.
"""

from lab.dynamics.relaxation import Relaxation, load_relaxation
from lab.dynamics.relaxation_fit import Segment, Stream, fit_stream

__all__ = [
    "Relaxation",
    "load_relaxation",
    "Segment",
    "Stream",
    "fit_stream",
]
