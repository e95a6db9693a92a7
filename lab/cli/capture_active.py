"""``python -m lab capture --active N --batch B``: active sampling on a rig, journaled and resumable.

Each batch (the initial design is batch 0) is picked by :func:`lab.learn.active.active_sampling`,
written to the journal as a plan (the ``active`` field of a ``# session`` note: the
batch's commands and log entry), then captured with the protocol
(:func:`lab.rig.capture.capture`, open-ended: the command list grows batch by batch).
A re-run reads the journal: a batch whose plan is journaled but not all captured is
finished first (from its plan, so nothing depends on refitting), then sampling goes on
from the samples so far -- the next batch depends only on the seed and those samples.
"""

from __future__ import annotations

import dataclasses
import functools
import sys

import numpy as np


def planned_batches(notes: list) -> list[dict]:
    """The batch plans in a journal's notes, one per batch (the last note of each
    ``n_before``: a batch resumed after a kill is planned again with the same content)."""
    plans = {}
    for tag, info in notes:
        if tag == "session" and "active" in info:
            plans[info["active"]["n_before"]] = info["active"]
    return [plans[k] for k in sorted(plans)]


def capture_active(args, robot, rig, protocol, journal, header: dict, command: str):
    """Capture ``args.active`` samples actively on the open ``rig``; returns the
    :class:`lab.rig.capture.Capture` of every sample (capture order) and the sampler's
    metadata (settings, ``n_batches``, the per-batch ``log``)."""
    from lab.cli.sampling import active_settings, print_batch
    from lab.learn.active import active_sampling
    from lab.learn.ensemble import train_ensemble
    from lab.rig.capture import capture, journal_samples

    settings = active_settings(args, robot)
    kwargs = settings.pop("kwargs")
    header = {**header, "sampler": settings}
    state = {"res": None}

    def run(u_all: np.ndarray, plan: dict | None):
        info = {"command": command, **({"active": plan} if plan else {})}
        state["res"] = capture(
            rig,
            u_all,
            journal,
            protocol,
            header=header,
            session_info=info,
            progress=not args.no_progress,
            open_ended=True,
        )
        return state["res"]

    u_done, y_done, notes = journal_samples(journal, robot.n_cables, protocol, header=header)
    plans = planned_batches(notes)
    if plans and plans[-1]["n_before"] + len(plans[-1]["u"]) > len(u_done):  # killed inside a batch
        plan = plans[-1]
        print(f"finishing batch {plan['entry']['batch']} as planned in {journal}", file=sys.stderr)
        res = run(np.vstack([u_done[: plan["n_before"]], np.array(plan["u"], dtype=float)]), plan)
        u_done, y_done = res.u_motor, res.p_tip_W
    n_journaled = len(u_done) if state["res"] is None else len(u_done) - state["res"].new_samples
    if n_journaled:
        print(f"resumed: {n_journaled} samples came from {journal}", file=sys.stderr)
    so_far, pending = [u_done], {}

    def on_pick(u_b, entry):
        pending["plan"] = {"n_before": int(entry["n_before"]), "u": u_b.tolist(), "entry": entry}

    def measure(u_b):
        res = run(np.vstack([*so_far, u_b]), pending.pop("plan"))
        return res.p_tip_W[-len(u_b) :]

    def on_batch(u_b, y_b, entry):
        so_far.append(u_b)
        print_batch(entry, args.active, sys.stderr)

    fit = functools.partial(train_ensemble, n_jobs=1)
    u, _, _ = active_sampling(
        robot,
        measure,
        args.active,
        args.batch,
        u_done=u_done,
        y_done=y_done,
        fit_ensemble=fit,
        on_pick=on_pick,
        on_batch=on_batch,
        **kwargs,
    )
    res = state["res"]
    if res is None or len(res.u_motor) != len(u):  # nothing captured by this run: read it all back
        res = run(u, None)
    log = [p["entry"] for p in planned_batches(res.notes)]
    res = dataclasses.replace(res, new_samples=len(u) - n_journaled)  # over this run's batches
    return res, {**settings, "n_batches": len(log), "log": log}
