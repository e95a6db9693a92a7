"""The batches of an active design captured on a rig: each planned in the journal, then measured.

An active design picks its next batch from the samples so far, so its capture journal is
open-ended (:func:`lab.capture.session.capture`). :class:`JournaledBatches` gives the
active-sampling loop its callables: :meth:`~JournaledBatches.on_pick` notes the batch's
plan (its commands and log entry, in the ``active`` field of the session note) and
:meth:`~JournaledBatches.measure` captures it. :meth:`~JournaledBatches.resume` reads a
journal back: a batch whose plan is journaled but not all captured is finished first, from
its plan (nothing depends on refitting), and sampling goes on from the samples so far.
"""

from __future__ import annotations

import dataclasses
import sys

import numpy as np

from lab.capture.protocol import Protocol
from lab.capture.session import Capture, capture, journal_samples
from lab.rig.base import Rig

__all__ = ["JournaledBatches", "planned_batches"]


def planned_batches(notes: list) -> list[dict]:
    """The batch plans in a journal's notes, one per batch (the last note of each
    ``n_before``: a batch resumed after a kill is planned again with the same content)."""
    plans = {}
    for tag, info in notes:
        if tag == "session" and "active" in info:
            plans[info["active"]["n_before"]] = info["active"]
    return [plans[k] for k in sorted(plans)]


class JournaledBatches:
    """Capture an active design's batches on the open ``rig`` into ``journal`` with
    ``protocol``; ``header`` (robot, rig, sampler settings) is what a resumed journal must
    match and ``command`` is noted in each session."""

    def __init__(self, rig: Rig, journal, protocol: Protocol, header: dict, command: str, *, progress=False, file=None):
        self.rig, self.journal, self.protocol = rig, journal, protocol
        self.header, self.command, self.progress = header, command, progress
        self.file = sys.stderr if file is None else file
        self.last: Capture | None = None  # every sample, after the latest capture call
        self._so_far: list[np.ndarray] = []
        self._plan: dict | None = None
        self._n_journaled = 0

    def _capture(self, u_all: np.ndarray, plan: dict | None) -> Capture:
        info = {"command": self.command, **({"active": plan} if plan else {})}
        self.last = capture(
            self.rig,
            u_all,
            self.journal,
            self.protocol,
            header=self.header,
            session_info=info,
            progress=self.progress,
            open_ended=True,
        )
        return self.last

    def resume(self) -> tuple[np.ndarray, np.ndarray]:
        """The samples so far, ``u`` (N, m) rad and ``y`` (N, 3) m, after finishing a batch
        that a kill interrupted (as planned in the journal)."""
        m = self.rig.robot.n_inputs
        u_done, y_done, notes = journal_samples(
            self.journal, m, self.protocol, header=self.header, markers=self.rig.robot.marker_names
        )
        plans = planned_batches(notes)
        if plans and plans[-1]["n_before"] + len(plans[-1]["u"]) > len(u_done):  # killed inside a batch
            plan = plans[-1]
            print(f"finishing batch {plan['entry']['batch']} as planned in {self.journal}", file=self.file)
            res = self._capture(np.vstack([u_done[: plan["n_before"]], np.array(plan["u"], dtype=float)]), plan)
            u_done, y_done = res.u_motor, res.p_tip_W
        self._n_journaled = len(u_done) if self.last is None else len(u_done) - self.last.new_samples
        if self._n_journaled:
            print(f"resumed: {self._n_journaled} samples came from {self.journal}", file=self.file)
        self._so_far = [u_done]
        return u_done, y_done

    def on_pick(self, u_batch: np.ndarray, entry: dict) -> None:
        """Keep the plan of the batch about to be measured (journaled with its capture)."""
        self._plan = {"n_before": int(entry["n_before"]), "u": u_batch.tolist(), "entry": entry}

    def measure(self, u_batch: np.ndarray) -> np.ndarray:
        """Capture the batch (B, m) rad after the samples so far; its tips (B, 3) m."""
        plan, self._plan = self._plan, None
        res = self._capture(np.vstack([*self._so_far, u_batch]), plan)
        return res.p_tip_W[-len(u_batch) :]

    def on_batch(self, u_batch: np.ndarray, y_batch: np.ndarray, entry: dict) -> None:
        """Count the measured batch among the samples so far."""
        self._so_far.append(u_batch)

    def finish(self, u: np.ndarray) -> tuple[Capture, list[dict]]:
        """Every sample of the design ``u`` (N, m) rad (read back if this run captured none)
        with ``new_samples`` counted over this run, and the log entries of the batches."""
        res = self.last
        if res is None or len(res.u_motor) != len(u):  # nothing captured by this run: read it all back
            res = self._capture(u, None)
        log = [p["entry"] for p in planned_batches(res.notes)]
        return dataclasses.replace(res, new_samples=len(u) - self._n_journaled), log
