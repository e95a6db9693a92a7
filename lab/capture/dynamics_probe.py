"""Exciting the rig to learn its dynamics: step responses and short random motions.

``python -m lab fit-dynamics`` learns the foam's relaxation filter
(:class:`~lab.dynamics.relaxation.Relaxation`) from what the motion capture sees while the
rig is driven through a :class:`ProbePlan`: ``n_steps`` random allowed commands each held
``step_hold_s`` (the slow mode seen to its end), then ``n_random`` commands held 0.3-1.5 s
(fast content that separates the modes), then a final hold. No reset in between: every
command is its own pose with its own equilibrium. The plan is a pure function of the
robot and the seed; :func:`run_probe` drives a rig through it with a
:class:`~lab.capture.recorder.StreamRecorder` and returns the
:class:`~lab.dynamics.relaxation_fit.Stream` to fit. Why these holds: ``docs/design/rig.md``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lab.capture.pace import LATE_FRACTION_ALLOWED, MIN_RATE_FRACTION
from lab.capture.recorder import StreamRecorder
from lab.description import RobotDescription
from lab.dynamics.relaxation_fit import Stream
from lab.errors import InputError, LabRuntimeError
from lab.rig.base import Rig
from lab.specs import Spec, at_most, non_negative_int, option, positive, positive_int

__all__ = [
    "MAX_MODES",
    "MAX_HOLD_S",
    "MAX_PROBE_S",
    "ProbeSpec",
    "ProbePlan",
    "probe_plan",
    "random_allowed_commands",
    "run_probe",
    "plan_info",
]

#: The most relaxation modes a probe's recording can tell apart.
MAX_MODES = 4
#: The longest hold of a step response, s: sixty times the default, far past the foam's
#: slowest relaxation (seconds); a longer one only keeps the servos loaded.
MAX_HOLD_S = 600.0
#: The longest probe, s (its holds, upper estimate): four hours of servos under load and of
#: motion capture, beyond which a session on the rig does not go.
MAX_PROBE_S = 4 * 3600.0
#: The most step responses and random motions of one probe.
MAX_STEPS = 1000
MAX_RANDOM = 10_000
#: Hold range of a random motion, s.
RANDOM_HOLD_S = (0.3, 1.5)


def _modes(v) -> str | None:
    problem = positive_int(v)
    if problem:
        return problem
    return None if v <= MAX_MODES else f"must be at most {MAX_MODES} (more relaxation modes cannot be told apart)"


def _seconds(v) -> str | None:
    if positive(v) is not None:
        return "must be a positive number of seconds"
    return None if v <= MAX_HOLD_S else f"must be at most {MAX_HOLD_S:g} s"


@dataclass(frozen=True)
class ProbeSpec(Spec):
    """How ``fit-dynamics`` excites the rig (:func:`probe_plan`) and how many relaxation
    modes it fits to the recording. Every count and hold is bounded, and so is the whole
    probe (:data:`MAX_PROBE_S`)."""

    n_steps: int = option(
        6, help="step responses, each held --step-hold-s", type=int, check=at_most(MAX_STEPS, positive_int)
    )
    n_random: int = option(
        40, help="random commands held 0.3-1.5 s each", type=int, check=at_most(MAX_RANDOM, non_negative_int)
    )
    modes: int = option(2, help="relaxation modes K to fit", type=int, check=_modes)
    step_hold_s: float = option(
        10.0,
        unit="s",
        help="hold of each step response, s: about four times the slowest time constant",
        type=float,
        check=_seconds,
    )

    def __post_init__(self):
        super().__post_init__()
        longest = self.longest_s
        if longest > MAX_PROBE_S:
            name = self.name_of
            raise self.field_error(
                f"{name('n_steps')} {self.n_steps} x {name('step_hold_s')} {self.step_hold_s:g} and "
                f"{name('n_random')} {self.n_random} hold the rig up to {longest / 3600:.1f} h: at most "
                f"{MAX_PROBE_S / 3600:g} h in one probe",
                "n_steps",
                "step_hold_s",
                "n_random",
            )

    @property
    def longest_s(self) -> float:
        """The probe's holds at their longest, s (each random motion held its upper bound)."""
        n_last = 1 if self.n_random else 0
        return (self.n_steps + n_last) * float(self.step_hold_s) + self.n_random * RANDOM_HOLD_S[1]

    def plan(self, robot: RobotDescription, seed: int = 0) -> ProbePlan:
        """The :class:`ProbePlan` of these settings for ``robot``, drawn with ``seed``."""
        return probe_plan(robot, seed, self.n_steps, self.n_random, self.step_hold_s)


@dataclass(frozen=True)
class ProbePlan:
    """Commands ``u_motor`` (n, m) rad with hold times ``hold_s`` (n,) s and a kind per
    command ("step" or "random"); ``settings``: how it was drawn (JSON-able)."""

    u_motor: np.ndarray
    hold_s: np.ndarray
    kinds: tuple
    settings: dict

    @property
    def duration_s(self) -> float:
        """Time held on the rig, not counting the motors' travel (s)."""
        return float(np.sum(self.hold_s))


def random_allowed_commands(robot: RobotDescription, n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` commands (n, m) rad uniform in ``[0, u_max]^m`` restricted to the safety rule
    (rejection sampling)."""
    out = np.empty((0, robot.n_inputs))
    for _ in range(1000):
        if len(out) >= n:
            break
        u = rng.uniform(0.0, robot.u_max_rad, (max(2 * n, 16), robot.n_inputs))
        out = np.vstack([out, u[robot.is_safe(u)]])
    if len(out) < n:
        raise InputError(f"robot {robot.name}: could not draw {n} commands its safety rule allows")
    return out[:n]


def probe_plan(
    robot: RobotDescription,
    seed: int = 0,
    n_steps: int = 6,
    n_random: int = 40,
    step_hold_s: float = 10.0,
    random_hold_s: tuple[float, float] = RANDOM_HOLD_S,
) -> ProbePlan:
    """The excitation of the module docstring: ``n_steps`` commands held ``step_hold_s`` s,
    then ``n_random`` held ``random_hold_s`` (lo, hi) s each, then one last long hold. The
    counts and the step hold are bounded as a :class:`ProbeSpec`'s (InputError)."""
    ProbeSpec(n_steps=n_steps, n_random=n_random, step_hold_s=step_hold_s)
    lo, hi = (float(v) for v in random_hold_s)
    if not (0 < lo <= hi <= MAX_HOLD_S):
        raise InputError(f"random hold times must satisfy 0 < lo <= hi <= {MAX_HOLD_S:g} s, got {lo}..{hi} s")
    rng = np.random.default_rng(seed)
    n_last = 1 if n_random else 0
    u = random_allowed_commands(robot, n_steps + n_random + n_last, rng)
    holds = np.concatenate(
        [np.full(n_steps, float(step_hold_s)), rng.uniform(lo, hi, n_random), np.full(n_last, float(step_hold_s))]
    )
    kinds = ("step",) * n_steps + ("random",) * n_random + ("step",) * n_last
    settings = {
        "seed": int(seed),
        "n_steps": int(n_steps),
        "n_random": int(n_random),
        "step_hold_s": float(step_hold_s),
        "random_hold_s": [lo, hi],
    }
    return ProbePlan(u, holds, kinds, settings)


def run_probe(rig: Rig, plan: ProbePlan, reading_period_s: float = 0.1, progress=None) -> Stream:
    """Drive ``rig`` through ``plan`` and return the recorded stream. The arm is first
    watched for one reading where it is (pose "initial"); each command is held from the
    moment the motors arrive, so no motion is cut short (the recorder times the arrivals,
    and the fit ramps each equilibrium over its motion). ``progress(i, n)`` after each
    command. The rig is left open.

    The recording's pace (:mod:`lab.capture.pace`) is the stream's ``pace``. A machine that
    fell behind the motion capture raises LabRuntimeError: the readings' windows stretch and
    the motors' arrivals are timed late, so the time constants fitted to them are wrong
    (0.002 s and 0.36 s came out for a foam of 0.1 s and 0.6 s), and a wrong filter fed
    forward does harm."""
    rec = StreamRecorder(rig, reading_period_s=reading_period_s)
    rec.read()
    for i, (u, hold) in enumerate(zip(plan.u_motor, plan.hold_s)):
        rec.go_to(u, f"{plan.kinds[i]}-{i}")
        rec.hold(hold)
        if progress is not None:
            progress(i + 1, len(plan.hold_s))
    pace = rec.meter.pace()
    if pace.behind:
        raise LabRuntimeError(
            f"the machine fell behind: the probe {pace.missed()}; a fit needs at least "
            f"{MIN_RATE_FRACTION:.0%} of the frames and late gaps after at most {LATE_FRACTION_ALLOWED:.0%} of them, "
            "or its time constants are those of the machine's load, not the foam's. Nothing was written: "
            "run again on a machine with less other work"
        )
    stream = rec.stream()
    stream.pace = pace.as_dict()
    return stream


def plan_info(plan: ProbePlan) -> dict:
    """The plan's settings and size, for a dynamic-model file's metadata."""
    return {**plan.settings, "n_commands": len(plan.hold_s), "duration_s": plan.duration_s}
