"""From a capture run to its dataset: the commands in capture order, the journal's identity,
and the rows, metadata and summary line written at the end.

A fixed design is captured in a seeded shuffled order (``--order shuffled``) and written
back in its own order; :func:`planned_commands` gives both. :func:`capture_header` is what
a resumed journal must match besides the protocol and the commands. :func:`captured_dataset`
turns the :class:`~lab.capture.session.Capture` into what :func:`lab.data.dataset.write_dataset`
writes (rows, ``OUT.json`` metadata) and the line printed after it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lab.capture.pace import MIN_RATE_FRACTION, samples_pace
from lab.capture.protocol import Protocol
from lab.capture.repeat_check import repeat_check_line
from lab.capture.session import Capture
from lab.capture.spec import CaptureSpec
from lab.description import RobotDescription

__all__ = ["CapturedDataset", "captured_dataset", "capture_header", "planned_commands", "rig_identity"]


def rig_identity(description: dict) -> dict:
    """What must not change when a capture is resumed: rig kind, robot, mesh, and the
    hash of every configuration the rig reports (``{name: {"sha256": ...}}``)."""
    out = {k: description[k] for k in ("kind", "robot", "mesh") if k in description}
    out.update({f"{k}.sha256": v["sha256"] for k, v in description.items() if isinstance(v, dict) and "sha256" in v})
    return out


def capture_header(robot: RobotDescription, description: dict) -> dict:
    """The journal header's robot and rig (``description``: the open rig's ``describe()``)."""
    return {"robot": {"name": robot.name, "sha256": robot.sha256}, "rig": rig_identity(description)}


def planned_commands(spec: CaptureSpec, robot: RobotDescription) -> tuple[np.ndarray, np.ndarray, dict, str]:
    """A fixed design's commands ``u`` (N, m) rad in dataset order, the capture order (N,)
    (``u[order]`` is captured), the sampler's metadata and what the run captures, in words."""
    design = spec.design
    u, sampler = design.commands(robot)
    sampler = {**sampler, "order": spec.order, "seed": spec.seed}
    order = np.random.default_rng(spec.seed).permutation(len(u)) if spec.order == "shuffled" else np.arange(len(u))
    what = f"{design.method} design" if design.kind == "design" else f"{design.levels}^{robot.n_inputs} grid"
    return u, order, sampler, f"{len(u)} safe commands of the {what}"


@dataclass(frozen=True)
class CapturedDataset:
    """Rows ``u_motor`` (N, m) rad and ``p_tip_W`` (N, 3) m in dataset order, the dataset's
    metadata and the line that reports the run.

    Attributes
    ----------
    u_motor : numpy.ndarray
        Commanded motor angles, shape (N, m), in rad, in dataset (design) order.
    p_tip_W : numpy.ndarray
        Settled tips, shape (N, 3), in m in frame W, in the same order.
    meta : dict
        The dataset's metadata (robot, rig, protocol, sampler, capture statistics,
        per-sample settle times), JSON-ready.
    summary : str
        The line (or two, with the repeat check) printed after writing it.
    y_W : numpy.ndarray or None
        Every marker (the tip first), shape (N, 3K), m, frame W, in the same order;
        ``p_tip_W`` when None (a robot observed at its tip alone).
    markers : tuple of str
        The K marker names, the tip first.
    input_units : tuple of str or None
        Each input's unit (``"rad"``, ``"N"``); None: all radians (today's robots).
    """

    u_motor: np.ndarray
    p_tip_W: np.ndarray
    meta: dict
    summary: str
    y_W: np.ndarray | None = None
    markers: tuple = ("tip",)
    input_units: tuple | None = None

    def write_args(self) -> dict:
        """The keyword arguments of :func:`lab.data.dataset.write_dataset` beyond today's
        (none for a tip-only robot of angle inputs, whose file is written as always).

        Returns
        -------
        dict
            ``markers`` and ``units`` when the robot has markers or inputs other than angles.
        """
        if len(self.markers) == 1 and self.input_units is None:
            return {}
        units = self.input_units or ("rad",) * self.u_motor.shape[1]
        return {"markers": tuple(self.markers), "units": tuple(units)}

    @property
    def outputs(self) -> np.ndarray:
        """The dataset's outputs y (N, 3K) m: every marker, the tip first."""
        return self.p_tip_W if self.y_W is None else self.y_W


def _stats(a: np.ndarray) -> dict:
    return {
        "mean": float(np.mean(a)),
        "median": float(np.median(a)),
        "p95": float(np.percentile(a, 95)),
        "max": float(np.max(a)),
    }


def captured_dataset(
    spec: CaptureSpec,
    robot: RobotDescription,
    description: dict,
    protocol: Protocol,
    res: Capture,
    u: np.ndarray,
    order: np.ndarray,
    sampler: dict,
    wall_s: float,
) -> CapturedDataset:
    """The dataset of a finished capture ``res`` of the commands ``u`` (N, m) rad (dataset
    order) captured as ``u[order]`` on the rig of ``description``; ``wall_s``: this run's
    wall-clock seconds."""
    n = len(u)
    y = np.empty_like(res.p_tip_W)
    y[order] = res.p_tip_W  # back to grid (design) order
    y_all = None
    if len(res.markers) > 1:
        y_all = np.empty_like(res.y_W)
        y_all[order] = res.y_W
    settled = np.empty(n, bool)
    settled[order] = res.settled
    per_sample = {name: np.empty(n) for name in ("sample_s", "settle_s")}
    for name, arr in per_sample.items():
        arr[order] = getattr(res, name)
    pred_std = np.empty(n)
    pred_std[order] = res.pred_std_m
    unsettled = np.flatnonzero(~settled)
    learned = [info for tag, info in res.notes if tag == "relaxation"]
    predictive = protocol.kind == "predictive"
    pace = samples_pace(res.n_frames, res.sample_s, description["frame_rate_hz"], order)
    pace["degraded"] = bool(predictive and pace["rows_behind"])
    meta = {
        "robot": {"name": robot.name, "sha256": robot.sha256, "description": robot.source},
        "rig": description,
        "protocol": protocol.as_dict(),
        "sampler": sampler,
        "capture": {
            "journal": str(spec.journal_path),
            "n_sessions": int(res.session.max()),
            "n_unsettled": int(len(unsettled)) if protocol.wait else None,
            "unsettled_rows": unsettled.tolist() if protocol.wait else None,
            "robot_time_s": res.robot_time_s,
            "rate_samples_per_hour": res.rate_per_hour,
            "sample_s": _stats(res.sample_s),
            "settle_s": _stats(res.settle_s),
            "invalid_frame_fraction": float(res.n_invalid_frames.sum() / max(1, res.n_frames.sum())),
            "wall_s_this_session": wall_s,
            "wall_s_all_sessions": res.wall_s,
            "protocol": protocol.kind,
            "repeat_check": res.repeat_check,
            "pace": pace,
            **(
                {
                    "relaxation": learned[-1] if learned else {"from": str(spec.protocol.dynamic_model)},
                    "n_predicted": int(res.predicted.sum()),
                    "pred_std_m": _stats(res.pred_std_m[res.predicted]) if res.predicted.any() else None,
                }
                if predictive
                else {}
            ),
        },
        "per_sample": {
            "settled": settled.astype(int).tolist(),
            **{k: v.tolist() for k, v in per_sample.items()},
            **({"pred_std_m": [None if np.isnan(v) else float(v) for v in pred_std]} if predictive else {}),
        },
        "command": spec.command,
    }
    summary = (
        f"wrote {n} samples to {spec.out} ({res.new_samples} new): {res.rate_per_hour:.0f} samples per "
        f"hour of robot time ({res.robot_time_s / 3600:.2f} h), {wall_s:.1f} s wall"
        + (f"; {len(unsettled)} not settled within {protocol.settle_timeout_s:g} s" if protocol.wait else "")
        + (f"; protocol {protocol.kind}, {int(res.predicted.sum())} predicted" if protocol.kind != "wait" else "")
    )
    if pace["degraded"]:
        behind = pace["rows_behind"]
        summary += (
            f"\nDEGRADED: {len(behind)} of {n} samples read the motion capture at under {MIN_RATE_FRACTION:.0%} of "
            f"its rate (the slowest {pace['min_sample_rate_hz']:.1f} Hz of {pace['nominal_rate_hz']:g} Hz; rows "
            f"{', '.join(map(str, behind[:10]))}{' ...' if len(behind) > 10 else ''}): the machine fell behind, "
            "and their predictions rest on stretched readings; capture them again on a machine with less other work"
        )
    check = repeat_check_line(res)
    units = None if robot.all_angle else tuple(robot.input_units)
    return CapturedDataset(u, y, meta, summary + (f"\n{check}" if check else ""), y_all, tuple(res.markers), units)
