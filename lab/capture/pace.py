"""Whether a real-time loop kept pace: the frames it read against those its clock promised.

A loop on a rig (streaming a trajectory, the ``fit-dynamics`` probe, a capture with the
predictive filter) reads motion-capture frames stamped on the rig clock. On an emulated
rig on virtual time every frame comes exactly one frame period after the last; on hardware,
a machine that falls behind -- a loaded laptop, a process starved of CPU -- reads fewer
frames than the rate promises, and sees long gaps between them (frames dropped while it was
busy). :func:`frame_pace` measures that from the frames' times alone: the achieved rate, the
longest gap and the gaps that missed their deadline (:data:`LATE_GAP_PERIODS` frame
periods or more). Each loop decides what its result needs (:data:`MIN_RATE_FRACTION`) and
either stops or marks its result degraded; the rules per loop: ``docs/design/rig.md``,
"Falling behind".
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = [
    "Pace",
    "PaceMeter",
    "frame_pace",
    "samples_pace",
    "LATE_GAP_PERIODS",
    "MIN_RATE_FRACTION",
    "LATE_FRACTION_ALLOWED",
]

#: A gap between two frames of this many frame periods or more missed a frame's deadline:
#: at least two frames in a row were never read.
LATE_GAP_PERIODS = 3.0
#: The least fraction of the nominal frame rate a loop's result can rest on: below half,
#: most of what the loop timed (a command's send, a reading's window) happened late.
MIN_RATE_FRACTION = 0.5
#: The most late gaps, as a fraction of the frames read, a loop's result can rest on: a few
#: hiccups of the operating system are harmless, a tenth of the frames following one is not.
LATE_FRACTION_ALLOWED = 0.1


@dataclass(frozen=True)
class Pace:
    """How a loop kept pace with the motion capture over ``span_s`` seconds of rig time.

    Attributes
    ----------
    n_frames : int
        Frames read.
    span_s : float
        Rig time the frames cover, s.
    nominal_rate_hz : float
        The motion capture's frame rate, Hz.
    max_gap_s : float
        Longest time between two frames read, s.
    n_late : int
        Gaps of :data:`LATE_GAP_PERIODS` frame periods or more.
    """

    n_frames: int
    span_s: float
    nominal_rate_hz: float
    max_gap_s: float
    n_late: int

    @property
    def expected_frames(self) -> int:
        """Frames the nominal rate promises over the span."""
        return int(round(self.span_s * self.nominal_rate_hz))

    @property
    def achieved_rate_hz(self) -> float:
        """Frames read per second of rig time, Hz (the nominal rate when the span is empty)."""
        return self.n_frames / self.span_s if self.span_s > 0 else self.nominal_rate_hz

    @property
    def fraction(self) -> float:
        """Achieved rate over the nominal rate (1 when the loop kept pace)."""
        return self.achieved_rate_hz / self.nominal_rate_hz

    @property
    def behind(self) -> bool:
        """Whether the loop fell behind what a result can rest on: under
        :data:`MIN_RATE_FRACTION` of the frames it was promised, or more than
        :data:`LATE_FRACTION_ALLOWED` of its frames after a late gap."""
        return self.fraction < MIN_RATE_FRACTION or self.n_late > LATE_FRACTION_ALLOWED * self.n_frames

    def as_dict(self) -> dict:
        """The measurement for a result file's metadata.

        Returns
        -------
        dict
            ``n_frames``, ``expected_frames``, ``span_s`` (s), ``nominal_rate_hz`` and
            ``achieved_rate_hz`` (Hz), ``max_gap_s`` (s), ``n_late_gaps`` and ``behind``.
        """
        return {
            "n_frames": self.n_frames,
            "expected_frames": self.expected_frames,
            "span_s": self.span_s,
            "nominal_rate_hz": self.nominal_rate_hz,
            "achieved_rate_hz": self.achieved_rate_hz,
            "max_gap_s": self.max_gap_s,
            "n_late_gaps": self.n_late,
            "behind": self.behind,
        }

    def missed(self) -> str:
        """What was missed, in words: "read 6 of 240 frames (2.5 %, 3.0 Hz of 120 Hz) ...".

        Returns
        -------
        str
            The counts, the rates and the longest gap.
        """
        pct = 100.0 * self.n_frames / max(1, self.expected_frames)
        return (
            f"read {self.n_frames} of {self.expected_frames} frames ({pct:.1f} %, "
            f"{self.achieved_rate_hz:.1f} Hz of {self.nominal_rate_hz:g} Hz), "
            f"{self.n_late} gaps of {LATE_GAP_PERIODS:g} frame periods or more, the longest {self.max_gap_s:.3f} s"
        )


class PaceMeter:
    """:func:`frame_pace` kept as frames come, without storing them (a probe reads hours of frames).

    Parameters
    ----------
    nominal_rate_hz : float
        The motion capture's frame rate, Hz.
    """

    def __init__(self, nominal_rate_hz: float):
        self.nominal_rate_hz = float(nominal_rate_hz)
        self.n_frames = self.n_late = 0
        self.t_first = self.t_last = float("nan")
        self.max_gap_s = 0.0

    def add(self, t_s: float) -> None:
        """Count one frame read.

        Parameters
        ----------
        t_s : float
            Its time, s on the rig clock (not before the last frame's).
        """
        t_s = float(t_s)
        if self.n_frames:
            gap = t_s - self.t_last
            self.max_gap_s = max(self.max_gap_s, gap)
            self.n_late += bool(gap >= LATE_GAP_PERIODS / self.nominal_rate_hz * (1 - 1e-9))
        else:
            self.t_first = t_s
        self.t_last = t_s
        self.n_frames += 1

    def pace(self) -> Pace:
        """The pace so far (span as in :func:`frame_pace`).

        Returns
        -------
        Pace
            Frames, span, rates, the longest gap and the late gaps.
        """
        span = self.t_last - self.t_first + 1.0 / self.nominal_rate_hz if self.n_frames else 0.0
        return Pace(self.n_frames, float(span), self.nominal_rate_hz, self.max_gap_s, self.n_late)


def frame_pace(t_s, nominal_rate_hz: float, span_s: float | None = None) -> Pace:
    """The pace of a loop that read frames at times ``t_s``.

    Parameters
    ----------
    t_s : array_like
        Times of the frames read, shape (n,), s on the rig clock, in order.
    nominal_rate_hz : float
        The motion capture's frame rate, Hz.
    span_s : float, optional
        Rig time the loop ran, s (default: from one frame period before the first frame to the
        last, so a loop that read every frame has :attr:`Pace.fraction` 1).

    Returns
    -------
    Pace
        Frames, span, rates, the longest gap and the late gaps.
    """
    t = np.asarray(t_s, float).ravel()
    period = 1.0 / float(nominal_rate_hz)
    if span_s is None:
        span_s = float(t[-1] - t[0] + period) if len(t) else 0.0
    gaps = np.diff(t) if len(t) > 1 else np.zeros(0)
    late = int(np.sum(gaps >= LATE_GAP_PERIODS * period * (1 - 1e-9)))
    return Pace(int(len(t)), float(span_s), float(nominal_rate_hz), float(gaps.max()) if len(gaps) else 0.0, late)


def samples_pace(n_frames, sample_s, nominal_rate_hz: float, rows=None) -> dict:
    """The pace of a capture's samples: each one's frames over its rig time.

    A predictive sample (:mod:`lab.capture.predictive`) is timed by the frames it reads; one
    read at under :data:`MIN_RATE_FRACTION` of the rate rests on readings whose windows
    stretched, so the capture marks its dataset degraded instead of stopping: its other
    samples stand, and the rows behind can be captured again.

    Parameters
    ----------
    n_frames : array_like
        Frames read per sample, shape (N,).
    sample_s : array_like
        Rig time per sample, shape (N,), s.
    nominal_rate_hz : float
        The motion capture's frame rate, Hz.
    rows : array_like, optional
        The dataset row of each sample, shape (N,) (default: their order).

    Returns
    -------
    dict
        ``nominal_rate_hz``, ``achieved_rate_hz`` (all samples) and ``min_sample_rate_hz``
        (the slowest sample), Hz; ``rows_behind``: the dataset rows of samples read under
        :data:`MIN_RATE_FRACTION` of the rate, in order.
    """
    n = np.asarray(n_frames, float)
    s = np.asarray(sample_s, float)
    rate = np.divide(n, s, out=np.full(len(n), float(nominal_rate_hz)), where=s > 0)
    rows = np.arange(len(n)) if rows is None else np.asarray(rows, int)
    behind = rate < MIN_RATE_FRACTION * nominal_rate_hz
    total = float(s.sum())
    return {
        "nominal_rate_hz": float(nominal_rate_hz),
        "achieved_rate_hz": float(n.sum() / total) if total > 0 else float(nominal_rate_hz),
        "min_sample_rate_hz": float(rate.min()) if len(rate) else float(nominal_rate_hz),
        "rows_behind": sorted(int(r) for r in rows[behind]),
    }
