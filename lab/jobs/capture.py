"""``python -m lab capture``: a design's commands measured on a rig into a journal, as a dataset.

:func:`run` takes the command's :class:`lab.capture.spec.CaptureSpec`: a fixed design
(grid or space-filling) is captured in its shuffled order by :func:`lab.capture.session.capture`; an active one
(``--active N --batch B``) runs :func:`lab.learn.active_design.run_active` -- the loop
``simulate`` runs too -- with the rig's side, each batch's plan journaled, then captured,
and a batch a kill interrupted finished from its plan, in
:class:`lab.capture.active.JournaledBatches`. It lives above both the rig and the
learned model, which a rig does not import; the command line writes the dataset it
returns. Killed or failed, the journal keeps every sample so far and the same spec
continues from it; the rig is closed (torque off) either way.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from lab.capture.dataset import CapturedDataset, capture_header, captured_dataset, planned_commands
from lab.capture.spec import CaptureSpec
from lab.errors import InputError

__all__ = ["run"]


def run(spec: CaptureSpec, *, file=None) -> CapturedDataset:
    """Capture ``spec``'s design on its rig.

    Parameters
    ----------
    spec : CaptureSpec
        The rig, robot, design, protocol, output and journal of the capture.
    file : file-like, optional
        Where progress lines go (default stderr).

    Returns
    -------
    CapturedDataset
        The dataset to write (rows in design order, or capture order for an active design)
        with its metadata and summary line. Raises InputError for bad input found before the
        rig moves (robot, dynamic model, design) or a journal of other settings, RigError
        when the rig fails; KeyboardInterrupt passes through after the rig is closed.
    """
    from lab.capture.session import capture
    from lab.description import load_robot
    from lab.rig import make_rig

    file = sys.stderr if file is None else file
    robot = load_robot(spec.robot)
    protocol, relaxation = spec.protocol.protocol(), spec.protocol.relaxation()
    if protocol.kind == "predictive" and len(robot.marker_names) > 1:  # before the rig moves
        raise InputError(
            f"--protocol predictive watches the tip alone; robot {robot.name!r} has markers "
            f"{', '.join(robot.marker_names[1:])}: capture it with --protocol wait"
        )
    active = spec.design.kind == "active"
    if active:
        from lab.learn.active_design import check_active

        check_active(spec.design, robot)  # before the rig moves
        what = f"{spec.design.active} safe commands picked actively in batches of {spec.design.batch}"
    else:
        u, order, sampler, what = planned_commands(spec, robot)
    print(f"{robot.name}: {what} on rig {str(spec.rig)!r}, journal {spec.journal_path}", file=file)
    t0 = time.perf_counter()
    with make_rig(spec.rig, robot, seed=spec.seed) as rig:
        description = rig.describe()
        header = capture_header(robot, description)
        if active:
            res, sampler = _capture_active(spec, robot, rig, protocol, header)
            u, order = res.u_motor, np.arange(len(res.u_motor))
        else:
            res = capture(
                rig,
                u[order],
                spec.journal_path,
                protocol,
                header={**header, "sampler": sampler},
                session_info={"command": spec.command},
                progress=spec.progress,
                relaxation=relaxation,
                repeat_check=True,
            )
    wall_s = time.perf_counter() - t0
    return captured_dataset(spec, robot, description, protocol, res, u, order, sampler, wall_s)


def _capture_active(spec: CaptureSpec, robot, rig, protocol, header: dict):
    """Capture the active design on the open ``rig``: the :class:`lab.capture.session.Capture`
    of every sample (capture order) and the sampler's metadata (settings, ``n_batches``,
    the per-batch ``log``)."""
    from lab.capture.active import JournaledBatches
    from lab.learn.active_design import active_settings, run_active

    settings = active_settings(spec.design, robot)
    batches = JournaledBatches(
        rig, spec.journal_path, protocol, {**header, "sampler": settings}, spec.command, progress=spec.progress
    )
    u_done, y_done = batches.resume()
    u, _, _ = run_active(
        spec.design,
        robot,
        batches.measure,
        u_done=u_done,
        y_done=y_done,
        on_pick=batches.on_pick,
        on_batch=batches.on_batch,
    )
    res, log = batches.finish(u)
    return res, {**settings, "n_batches": len(log), "log": log}
