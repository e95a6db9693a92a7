"""Chapter 2's graders: encoder ticks, the settle test, and one sample by the capture protocol.

Each ``check_*`` takes the student's function, draws its own cases from its own seeded
``np.random.default_rng`` (the chapter's random stream is untouched) and calls
:func:`lab.course.grade` against ``lab``'s own implementation:
:func:`lab.rig.dynamixel_units.ticks_from_u` (the bus code) for exercise 2.1,
:class:`lab.capture.SettleDetector` for 2.2 and :func:`lab.capture.measure` with the default
:class:`lab.capture.Protocol` for 2.3. The references live here, out of the student's sight: a
grader cell in ``notebooks/02_data_capture.ipynb`` is one import and one call.

Exercise 2.3 runs the student's capture and ``measure`` on two identical emulated rigs
(same body, same motion-capture seed, same history: a larger command held for 8 s, so the
cables hold friction play and the foam still creeps). Two captures by the protocol agree to
a reading's noise (~0.1 mm); one without the reset is ~0.2-0.8 mm off, one without waiting
millimetres: the tolerance, :data:`CAPTURE_TOL_M` per coordinate, sits between
(``tests/test_course_ch01_02.py`` checks those wrong captures).
"""

from __future__ import annotations

import copy

import numpy as np

from lab.capture import Protocol, SettleDetector, measure
from lab.course.grading import Grade, grade
from lab.rig import RigError, TwinRig
from lab.rig.dynamixel_units import ticks_from_u

__all__ = ["check_goal_ticks", "check_first_settled", "check_capture_sample", "CAPTURE_TOL_M", "capture_cases"]

#: exercise 2.3: the student's recorded tip and measure's may differ by this much per coordinate, m
CAPTURE_TOL_M = 2.5e-4
#: exercise 2.3: rig time a capture may take before the grader stops it, s
CAPTURE_LIMIT_S = 120.0


def check_goal_ticks(student, u_max_rad: float, *, case: int | None = None, show: bool = True) -> Grade:
    """Exercise 2.1: ``student(u_rad (n,), zero_ticks (n,), direction (n,)) -> ticks (n,)``
    on random angles in [0, ``u_max_rad``], offsets and mounting directions, exactly."""
    rng = np.random.default_rng(22)
    cases = [(rng.uniform(0, u_max_rad, n), rng.integers(0, 4096, n), rng.choice([-1, 1], n)) for n in (1, 3, 6, 10)]
    return grade(
        "goal ticks",
        student,
        ticks_from_u,
        cases,
        show=show,
        case=case,
        checker=check_goal_ticks,
        rtol=0,
        atol=0,
        hint="one revolution is 4096 ticks; round the angle to whole ticks, then turn it the way the spool "
        "is mounted and count from the motor's zero",
    )


def _first_settled_lab(readings_W, n_previous=20, tol_m=1e-4):
    detector = SettleDetector(n_previous, tol_m)
    return next((k for k, r in enumerate(readings_W) if detector.update(r)), -1)


def check_first_settled(student, *, case: int | None = None, show: bool = True) -> Grade:
    """Exercise 2.2: ``student(readings_W (N, 3) m, n_previous, tol_m) -> index or -1`` on
    creeping, noisy, partly occluded (NaN) sequences, against :class:`lab.capture.SettleDetector`."""
    rng = np.random.default_rng(21)
    cases = []
    for tau, noise in ((0.5, 2e-5), (1.5, 5e-5), (3.0, 1e-5), (0.2, 3e-4)):
        t = np.arange(0, 8, 0.1)
        creep = 5e-3 * np.exp(-t / tau)[:, None] * np.array([1.0, 0.3, -0.5])
        readings = creep + noise * rng.standard_normal(creep.shape)
        readings[rng.random(len(t)) < 0.1] = np.nan  # occluded readings
        cases += [(readings, 20, 1e-4), (readings, 5, 3e-4)]
    return grade(
        "the settle test",
        student,
        _first_settled_lab,
        cases,
        show=show,
        case=case,
        checker=check_first_settled,
        hint="compare with the mean of the previous n_previous *valid* readings, then add the current one",
    )


class GraderTwin(TwinRig):
    """An emulated rig that stops a capture running past ``CAPTURE_LIMIT_S`` of rig time, or
    polling the motors without letting time pass (a loop that would never end)."""

    def arm(self) -> None:
        """Start the clock of one capture."""
        self._limit_s, self._polls = self.now() + CAPTURE_LIMIT_S, 0

    def next_frame(self):
        if self.now() > getattr(self, "_limit_s", np.inf):
            raise RigError(f"the capture ran for more than {CAPTURE_LIMIT_S:g} s of rig time")
        self._polls = 0
        return super().next_frame()

    def present_u(self):
        self._polls = getattr(self, "_polls", 0) + 1
        if self._polls > 10_000:
            raise RigError("present_u polled 10000 times without a frame: time passes only as frames are read")
        return super().present_u()


def capture_cases(robot, seed: int = 24, n_cases: int = 4) -> list[tuple]:
    """Exercise 2.3's cases: (history (m,) rad, command (m,) rad, motion-capture seed). The
    history winds one to three cables to 1.5 rad..u_max; the command lets them out to
    0.3-0.7 of that, so the cables' play and the creep both point the wrong way."""
    rng = np.random.default_rng(seed)
    cases = []
    while len(cases) < n_cases:
        history = rng.uniform(0.5, 1.0, robot.n_inputs) * robot.u_max_rad * (rng.random(robot.n_inputs) < 0.7)
        if history.max() < 0.5 * robot.u_max_rad or not robot.is_safe(history[None])[0]:
            continue
        cases.append((history, np.round(history * rng.uniform(0.3, 0.7, robot.n_inputs), 2), 100 + len(cases)))
    return cases


def check_capture_sample(student, body, *, case: int | None = None, show: bool = True) -> Grade:
    """Exercise 2.3: ``student(rig, u_motor (m,) rad) -> p_tip_W (3,) m``, one sample by the
    protocol (reset, wait until settled, record), against :func:`lab.capture.measure` on an
    identical emulated rig, to :data:`CAPTURE_TOL_M` per coordinate.

    ``body``: the chapter's :class:`lab.rig.AsBuiltBody`, not yet driven by any rig; each
    case drives its own shallow copy (the copies share its equilibrium cache, nothing else)."""
    if body.time_s != 0.0:
        raise ValueError("check_capture_sample needs a body no rig has driven yet (its time is not 0)")
    twins, cases = {}, []
    for history, u, seed in capture_cases(body.robot):
        pair = []
        for _ in range(2):
            rig = GraderTwin(body.robot, seed=seed, body=copy.copy(body))
            rig.send(history)
            rig.wait(8.0)
            pair.append(rig)
        twins[id(pair[0])] = pair[1]
        cases.append((pair[0], u))

    def capture(rig, u_motor):
        rig.arm()
        return student(rig, u_motor)

    return grade(
        "one sample by the protocol",
        capture,
        lambda rig, u_motor: measure(twins[id(rig)], u_motor, Protocol()).p_tip_W,
        cases,
        show=show,
        case=case,
        checker=check_capture_sample,
        given=student,
        rtol=0.0,
        atol=CAPTURE_TOL_M,
        hint="the rig has just held a larger command: erase its history first (all cables in together, then "
        "out), wait for the motors each time, then read until the settle test passes",
    )
