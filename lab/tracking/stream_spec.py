"""How a trajectory is streamed: :class:`StreamSpec`, its defaults and its bounds.

The settings of :func:`lab.tracking.stream.stream_trajectory` -- the period, the number of
periods, the settled lead-in, the command rate and the inversion's smoothing -- as one
frozen spec whose fields carry the ``track`` flags (``--period-s``, ``--n-periods``,
``--lead-in-s``, ``--command-rate-hz``). Every value is bounded, and so is the run as a
whole (:data:`MAX_KNOTS` commands), so that a streamed run always ends. Why the defaults
are what they are: ``docs/design/tracking.md``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from lab.specs import Spec, at_most, finite, non_negative, option, positive_int

__all__ = [
    "StreamSpec",
    "default_n_periods",
    "DEFAULT_COMMAND_RATE_HZ",
    "DEFAULT_LEAD_IN_S",
    "MIN_TRANSIENT_S",
    "PERIOD_RANGE_S",
    "COMMAND_RATE_RANGE_HZ",
    "MAX_LEAD_IN_S",
    "MAX_KNOTS",
]

DEFAULT_COMMAND_RATE_HZ = 20.0
#: Settled lead-in at the first command, s (four slow time constants of the shipped twin).
DEFAULT_LEAD_IN_S = 10.0
#: Motion before the measured period, s: an open loop's start-up transient dies out.
MIN_TRANSIENT_S = 8.0
PERIOD_RANGE_S = (0.5, 600.0)
#: Commands per second a rig is sent: the servos' bus and the motion capture keep up to 200.
COMMAND_RATE_RANGE_HZ = (1.0, 200.0)
#: The longest lead-in, s: sixty times the default, far past the slowest relaxation of the foam.
MAX_LEAD_IN_S = 600.0
#: The most commands (knots) of one run: periods x period x rate.
MAX_KNOTS = 20_000


def _within(lo: float, hi: float, unit: str):
    def check(v):
        return None if finite(v) is None and lo <= v <= hi else f"must lie in [{lo:g}, {hi:g}] {unit}"

    return check


def default_n_periods(period_s: float) -> int:
    """Periods streamed by default: enough that at least :data:`MIN_TRANSIENT_S` of motion
    precede the last (measured) one, and never fewer than 2."""
    return max(2, 1 + math.ceil(MIN_TRANSIENT_S / float(period_s) - 1e-9))


@dataclass(frozen=True)
class StreamSpec(Spec):
    """How a trajectory is streamed: ``period_s`` (s), ``n_periods`` (None: enough motion
    before the measured last period, :func:`default_n_periods`), ``command_rate_hz``,
    ``lead_in_s`` (s) and the inversion's ``smoothing``. Every value is bounded, and so is
    the run: at most :data:`MAX_KNOTS` commands.

    Attributes
    ----------
    period_s : float
        One period of the trajectory, s, in :data:`PERIOD_RANGE_S`.
    n_periods : int or None
        Periods streamed (None: :func:`default_n_periods`).
    lead_in_s : float
        Settling at the first command before the motion, s, at most :data:`MAX_LEAD_IN_S`.
    command_rate_hz : float
        Commands per second, Hz, in :data:`COMMAND_RATE_RANGE_HZ`.
    smoothing : float
        Smoothing of the relaxation filter's inversion (>= 0).
    """

    period_s: float = option(
        dataclasses.MISSING,
        type=float,
        check=_within(*PERIOD_RANGE_S, "s"),
        unit="s",
        help="stream the trajectory continuously as one period of this many seconds (2-20 s typical) "
        "instead of settling at each point; error over the last period (default: settle at each point)",
    )
    n_periods: int | None = option(
        None,
        type=int,
        check=positive_int,
        help="with --period-s: periods streamed (default: enough for 8 s of motion before the last, >= 2)",
    )
    lead_in_s: float = option(
        DEFAULT_LEAD_IN_S,
        type=float,
        check=at_most(MAX_LEAD_IN_S, non_negative, " s"),
        unit="s",
        help="with --period-s: settle at the first command first, s",
    )
    command_rate_hz: float = option(
        DEFAULT_COMMAND_RATE_HZ,
        type=float,
        check=_within(*COMMAND_RATE_RANGE_HZ, "Hz"),
        unit="Hz",
        help="with --period-s: commands per second",
    )
    smoothing: float = option(1e-3, cli=False, check=non_negative, help="smoothing of the filter's inversion")

    def __post_init__(self):
        super().__post_init__()
        if self.n_knots > MAX_KNOTS:
            name = self.name_of
            raise self.field_error(
                f"{name('n_periods')} {self.periods} x {name('period_s')} {self.period_s:g} x "
                f"{name('command_rate_hz')} {self.command_rate_hz:g} is {self.n_knots} commands: at most "
                f"{MAX_KNOTS} in one run",
                "n_periods",
                "period_s",
                "command_rate_hz",
            )

    @property
    def periods(self) -> int:
        """Periods streamed: ``n_periods``, or :func:`default_n_periods`."""
        return default_n_periods(self.period_s) if self.n_periods is None else int(self.n_periods)

    @property
    def n_knots(self) -> int:
        """Commands of the run (knots, the first one included)."""
        return int(round(self.periods * float(self.period_s) * float(self.command_rate_hz))) + 1
