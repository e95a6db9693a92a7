"""Exciting the rig to learn its dynamics: step responses and short random motions.

``python -m lab fit-dynamics`` learns the foam's relaxation filter
(:class:`~lab.learn.relaxation.Relaxation`) from what the motion capture sees while the rig
is driven through a :class:`ProbePlan`:

1. **step responses** (``n_steps``): random allowed commands, each held ``step_hold_s``
   (default 10 s, four times a slow time constant of 2.5 s: the slow mode is seen to its
   end, which pins the equilibria and so the weights). No reset in between: every command
   is its own pose with its own equilibrium (the fit finds them), so hysteresis does no harm;
2. **random motions** (``n_random``): random allowed commands held 0.3-1.5 s (uniform)
   after the motors arrive, each interrupting the creep toward the last: fast content that
   separates the fast mode from the slow one;
3. a final hold of ``step_hold_s``, so the last equilibria are seen too.

Commands are drawn uniformly in ``[0, u_max]`` per motor and kept if the robot's safety
rule allows them. The plan is a pure function of the robot and the seed; :func:`run_probe`
drives a rig through it with a :class:`~lab.rig.recorder.StreamRecorder` and returns the
:class:`~lab.learn.relaxation_fit.Stream` to fit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lab.description import RobotDescription
from lab.errors import InputError
from lab.learn.relaxation_fit import Stream
from lab.rig.base import Rig
from lab.rig.recorder import StreamRecorder

__all__ = ["ProbePlan", "probe_plan", "random_allowed_commands", "run_probe"]


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
    out = np.empty((0, robot.n_cables))
    for _ in range(1000):
        if len(out) >= n:
            break
        u = rng.uniform(0.0, robot.u_max_rad, (max(2 * n, 16), robot.n_cables))
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
    random_hold_s: tuple[float, float] = (0.3, 1.5),
) -> ProbePlan:
    """The excitation of the module docstring: ``n_steps`` commands held ``step_hold_s`` s,
    then ``n_random`` held ``random_hold_s`` (lo, hi) s each, then one last long hold."""
    if n_steps < 1 or n_random < 0:
        raise InputError(f"need n_steps >= 1 and n_random >= 0, got {n_steps} and {n_random}")
    lo, hi = (float(v) for v in random_hold_s)
    if not (step_hold_s > 0 and 0 < lo <= hi):
        raise InputError(f"hold times must be positive (step {step_hold_s} s, random {lo}..{hi} s)")
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
    command. The rig is left open."""
    rec = StreamRecorder(rig, reading_period_s=reading_period_s)
    rec.read()
    for i, (u, hold) in enumerate(zip(plan.u_motor, plan.hold_s)):
        rec.go_to(u, f"{plan.kinds[i]}-{i}")
        rec.hold(hold)
        if progress is not None:
            progress(i + 1, len(plan.hold_s))
    return rec.stream()


def plan_info(plan: ProbePlan) -> dict:
    """The plan's settings and size, for a dynamic-model file's metadata."""
    return {**plan.settings, "n_commands": len(plan.hold_s), "duration_s": plan.duration_s}
