"""Stage 9b: following a trajectory on a rig, open loop, streamed or closed loop.

:func:`run_trajectory` (:mod:`.track`) solves the IK for every target, sends the commands
to any :class:`lab.rig.Rig` and records where the tip settled; :mod:`.stream` commands a
trajectory continuously at a period, and :mod:`.closed_loop` corrects the commands from
measured tips (ILC or per-point feedback). One ``python -m lab track`` run from its
settings is :mod:`lab.jobs.track`, with its measured points kept in :mod:`.points`;
with ``--rig none`` there is no rig, and :func:`run_offline`
(:mod:`.offline`) writes the IK's commands for a lab's own robot (:mod:`.solved_targets`). The studies built on
these (Table I, the sim-to-real and data-efficiency curves) are in :mod:`lab.studies`; the
design notes in ``docs/design/tracking.md``.
"""

from lab.tracking.closed_loop import (
    DEFAULT_GAIN,
    MAX_PASSES,
    Correction,
    correct_command,
    damped_pinv,
    run_closed_loop,
)
from lab.tracking.offline import run_offline, solve_targets
from lab.tracking.points import PointLog
from lab.tracking.solved_targets import SolvedTargets
from lab.tracking.stream import StreamPlan, StreamResult, stream_trajectory
from lab.tracking.stream_spec import StreamSpec
from lab.tracking.track import (
    REQUIRED_KEYS,
    TRACK_PROTOCOL,
    TrackResult,
    TrackResultError,
    read_result,
    run_trajectory,
    write_result,
)

__all__ = [
    "SolvedTargets",
    "run_offline",
    "solve_targets",
    "PointLog",
    "DEFAULT_GAIN",
    "MAX_PASSES",
    "Correction",
    "correct_command",
    "damped_pinv",
    "run_closed_loop",
    "TRACK_PROTOCOL",
    "REQUIRED_KEYS",
    "TrackResultError",
    "TrackResult",
    "run_trajectory",
    "write_result",
    "read_result",
    "StreamSpec",
    "StreamPlan",
    "StreamResult",
    "stream_trajectory",
]
