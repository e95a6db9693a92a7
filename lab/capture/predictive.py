"""The predictive capture protocol: predict the settled tip from the start of its transient.

The waiting protocol (:mod:`lab.capture.protocol`) waits out the foam's creep after every
command. The predictive one keeps its reset but stops early: the first ``n_learn``
samples are measured by waiting while the whole stream is recorded
(:class:`~lab.capture.recorder.StreamRecorder`) and a relaxation filter is fitted to it
(:func:`lab.dynamics.relaxation_fit.fit_stream`, written to the journal so a resumed run
reuses it); every later sample is recorded as soon as the motors arrived and a Kalman
filter (:class:`~lab.capture.tip_filter.TipFilter`) predicts its settled tip with a 3-D std
below ``predict_tol_m`` (``settled = 0`` when not confident within ``settle_timeout_s``).
A relaxation fitted by ``python -m lab fit-dynamics`` skips the learning. Occlusions and
faults behave as in the waiting protocol. Details: ``docs/design/rig.md``.
"""

from __future__ import annotations

import numpy as np

from lab.capture.markers import reset_command
from lab.capture.protocol import Protocol, Sample, SettleDetector
from lab.capture.recorder import StreamRecorder
from lab.capture.tip_filter import TipFilter
from lab.dynamics.relaxation import Relaxation
from lab.dynamics.relaxation_fit import fit_stream
from lab.rig.base import Rig, RigError


class PredictiveSampler:
    """Measures samples with the predictive protocol, one call per command; keeps the
    filter's state from sample to sample. Calling it with a command ``u_motor`` (m,) rad
    returns that command's :class:`~lab.capture.protocol.Sample`.

    Parameters
    ----------
    rig : Rig
        The rig to measure on.
    protocol : Protocol
        The settings; ``kind`` predictive.
    relaxation : Relaxation, optional
        A relaxation fitted before (e.g. by ``fit-dynamics``, or read from a resumed
        journal): skips the learning phase. None: learn it from the first ``n_learn`` samples.
    note : callable, optional
        ``note(tag, info)``: where to journal the learned relaxation (a
        :class:`~lab.capture.journal.Journal`'s ``note``).
    """

    def __init__(self, rig: Rig, protocol: Protocol, relaxation: Relaxation | None = None, note=None):
        self.rig, self.protocol = rig, protocol
        self.rec = StreamRecorder(rig, protocol.reading_period_s, protocol.max_occlusion_s, protocol.motor_tol_rad)
        self.note = note
        self.relax = relaxation
        self.filter = None if relaxation is None else self._new_filter(relaxation)
        self.n_learned = 0
        self._learn_from = 0  # first move of the learning phase in the recorder

    def _new_filter(self, relax: Relaxation) -> TipFilter:
        return TipFilter(relax, process_noise_m2_per_s=self.protocol.process_noise_m2_per_s)

    def __call__(self, u_motor) -> Sample:
        if self.relax is None:
            return self._learn(u_motor)
        return self._predict(u_motor)

    # ------------------------------------------------------------------ phase 1: learn
    def _learn(self, u_motor) -> Sample:
        p, rec = self.protocol, self.rec
        t_start, frames0, invalid0 = self.rig.now(), rec.n_frames, rec.n_invalid
        m = self.rig.robot.n_inputs
        # each sample's reset pose is its own: the cables' play leaves it where the previous sample
        # came from (the release then erases that memory, so the rest pose is one and the same)
        rec.go_to(reset_command(self.rig.robot, p), f"reset{self.n_learned}", p.motion_timeout_s)
        rec.go_to(np.zeros(m), "rest", p.motion_timeout_s)
        goal = rec.command(u_motor, f"target{self.n_learned}")
        move, detector = rec.move, SettleDetector(p.n_previous, p.settle_tol_m)
        last_valid, settled, n_readings = None, False, 0
        while True:
            _, reading, n = rec.read()
            n_readings += 1
            if n:
                last_valid = reading
            settled = detector.update(reading)
            self._check_motion(move, goal)
            if move.arrived and (
                settled or (self.rig.now() - move.t_command_s > p.settle_timeout_s and last_valid is not None)
            ):
                break
        sample = self._sample(goal, last_valid, settled, t_start, move, n_readings, frames0, invalid0)
        sample.deviation_m = detector.deviation_m
        self.n_learned += 1
        if self.n_learned >= p.n_learn:
            self._fit()
        return sample

    def _fit(self) -> None:
        """Fit the relaxation to the learning phase's stream and start the filter from it."""
        relax, report = fit_stream(self.rec.stream(self._learn_from), self.protocol.n_modes)
        self.relax = relax
        if self.note is not None:
            self.note(
                "relaxation",
                {
                    "tau_s": relax.tau_s.tolist(),
                    "weight": relax.weight.tolist(),
                    "noise_sigma_m": relax.noise_sigma_m,
                    "rms_m": report["rms_m"],
                    "n_readings": report["n_readings"],
                    "n_samples": self.n_learned,
                },
            )
        f = self.filter = self._new_filter(relax)
        eq = report["equilibria"]
        tol = max(relax.noise_sigma_m, 1e-5)
        f.set("reset", eq[f"reset{self.n_learned - 1}"], tol)
        f.set("rest", eq["rest"], tol)
        last = eq[f"target{self.n_learned - 1}"]
        f.set("target", last, tol)
        f.set("modes", last, 3 * tol)  # settled there by the waiting rule
        f.t_s = self.rec.t_s[-1]

    # ---------------------------------------------------------------- phase 2: predict
    def _predict(self, u_motor) -> Sample:
        p, rec, f = self.protocol, self.rec, self.filter
        t_start, frames0, invalid0 = self.rig.now(), rec.n_frames, rec.n_invalid
        m = self.rig.robot.n_inputs
        # The reset pose depends on the cables' play on the way in: known only roughly in advance.
        f.jitter("reset", p.reset_jitter_m)
        f.jitter("rest", p.pose_jitter_m)
        self._move(reset_command(self.rig.robot, p), "target", "reset")
        self._move(np.zeros(m), "reset", "rest")
        f.forget("target")
        goal = rec.command(u_motor, "target")
        move, n_readings, after, settled = rec.move, 0, 0, False
        while True:
            t, reading, n = rec.read()
            n_readings += 1
            self._advance(t, "rest", "target")
            f.update(reading, n)
            self._check_motion(move, goal)
            after += move.arrived
            std3 = np.sqrt(3.0) * f.std("target")
            if after >= p.min_readings_after_arrival and std3 <= p.predict_tol_m:
                settled = True
                break
            if move.arrived and self.rig.now() - move.t_command_s > p.settle_timeout_s:
                break
        sample = self._sample(
            goal, f.x[f.index["target"]].copy(), settled, t_start, move, n_readings, frames0, invalid0
        )
        sample.pred_std_m, sample.predicted = float(std3), True
        return sample

    def _move(self, u_motor, pose_from: str, pose_to: str) -> None:
        goal = self.rec.command(u_motor, pose_to)
        move = self.rec.move
        while not move.arrived:
            t, reading, n = self.rec.read()
            self._advance(t, pose_from, pose_to)
            self.filter.update(reading, n)
            self._check_motion(move, goal)

    def _advance(self, t_s: float, pose_from: str, pose_to: str) -> None:
        """Advance the filter to ``t_s`` through the latest move (split where its ramp starts and ends)."""
        f, move = self.filter, self.rec.move
        if f.t_s is None:
            f.t_s = t_s
            return
        cuts = [c for c in (move.t_command_s, move.t_arrived_s) if c is not None and f.t_s < c < t_s]
        for t_end in [*cuts, t_s]:
            f.advance(t_end, pose_from, pose_to, move.fraction(f.t_s), move.fraction(t_end))

    def _check_motion(self, move, goal) -> None:
        if not move.arrived and self.rig.now() - move.t_command_s > self.protocol.motion_timeout_s:
            raise RigError(
                f"motors did not reach {goal.tolist()} rad within {self.protocol.motion_timeout_s} s "
                f"(present {self.rig.present_u().tolist()} rad)"
            )

    def _sample(self, goal, p_tip_W, settled, t_start, move, n_readings, frames0, invalid0) -> Sample:
        return Sample(
            goal,
            p_tip_W,
            self.rec.present_u.copy(),
            bool(settled),
            t_start,
            move.t_command_s,
            move.t_arrived_s,
            self.rig.now(),
            n_readings,
            float("nan"),
            self.rec.n_frames - frames0,
            self.rec.n_invalid - invalid0,
        )
