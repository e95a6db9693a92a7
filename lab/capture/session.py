"""A capture run: the protocol (:mod:`lab.capture.protocol`) over a list of commands, resumable.

:func:`capture` runs a list of commands through an append-only :class:`~lab.capture.journal.Journal`,
one fsynced line per sample: killed and started again with the same settings, it
continues with the first command not yet in the journal. With ``repeat_check`` the first
command is measured once more after the last (:mod:`.repeat_check`): a robot that creeps
over minutes, drifts or is knocked gives another tip for it, and the capture says so.
``python -m lab capture``
(:func:`lab.jobs.capture.run`) adds the design, the rig and the dataset.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from lab.capture.journal import Journal, journal_columns, marker_columns
from lab.capture.protocol import Protocol, measure
from lab.capture.repeat_check import repeat_note
from lab.errors import InputError
from lab.rig.base import Rig


@dataclass
class Capture:
    """All samples of a capture in command order, and the journal's notes.

    Attributes
    ----------
    u_motor : numpy.ndarray
        Commands, shape (N, m), in rad.
    p_tip_W : numpy.ndarray
        Recorded tips, shape (N, 3), in m in frame W.
    settled : numpy.ndarray
        Whether each sample settled, shape (N,), bool.
    sample_s : numpy.ndarray
        Robot time (s) from the start of the reset to the record, shape (N,).
    settle_s : numpy.ndarray
        Time (s) from the command to the record, shape (N,).
    deviation_m : numpy.ndarray
        The settle test's last deviation (m), shape (N,).
    n_frames, n_invalid_frames : numpy.ndarray
        Frames read per sample and the occluded ones, shape (N,), int.
    session : numpy.ndarray
        The session (1, 2, ...) that recorded each sample, shape (N,), int.
    notes : list of tuple
        The journal's notes (``session`` / ``session-end`` / ... lines) as (tag, dict).
    new_samples : int
        Samples recorded by this call.
    pred_std_m : numpy.ndarray or None
        Predictive protocol: 3-D std (m) of each predicted tip, shape (N,); NaN when waited for.
    predicted : numpy.ndarray or None
        Predictive protocol: recorded from the prediction, shape (N,), bool.
    y_W : numpy.ndarray or None
        Every marker (the tip first), shape (N, 3K), m, frame W; ``p_tip_W`` when None
        (a robot observed at its tip alone).
    markers : tuple of str
        The K marker names, the tip first.
    """

    u_motor: np.ndarray
    p_tip_W: np.ndarray
    settled: np.ndarray
    sample_s: np.ndarray
    settle_s: np.ndarray
    deviation_m: np.ndarray
    n_frames: np.ndarray
    n_invalid_frames: np.ndarray
    session: np.ndarray
    notes: list
    new_samples: int
    pred_std_m: np.ndarray | None = None
    predicted: np.ndarray | None = None
    y_W: np.ndarray | None = None
    markers: tuple = ("tip",)

    @property
    def repeat_check(self) -> dict | None:
        """The journal's ``repeat-check`` note (written by :func:`capture`), or None."""
        found = [info for tag, info in self.notes if tag == "repeat-check"]
        return found[-1] if found else None

    def __post_init__(self):
        n = len(self.u_motor)
        if self.pred_std_m is None:
            self.pred_std_m = np.full(n, np.nan)
        if self.predicted is None:
            self.predicted = np.zeros(n, dtype=bool)
        if self.y_W is None:
            self.y_W = self.p_tip_W

    @property
    def wall_s(self) -> float:
        """Wall-clock seconds of all sessions that ended (killed ones leave no end note)."""
        return float(sum(info.get("wall_s", 0.0) for tag, info in self.notes if tag == "session-end"))

    @property
    def robot_time_s(self) -> float:
        """Robot time (s) of all samples: the sum of ``sample_s``."""
        return float(self.sample_s.sum())

    @property
    def rate_per_hour(self) -> float:
        """Samples per hour of robot time (reset + motion + settling)."""
        return 3600.0 * len(self.sample_s) / self.robot_time_s if self.robot_time_s > 0 else float("nan")


def capture(
    rig: Rig,
    commands,
    journal_path,
    protocol: Protocol = Protocol(),
    *,
    header: dict | None = None,
    session_info: dict | None = None,
    progress: bool = False,
    open_ended: bool = False,
    relaxation=None,
    repeat_check: bool = False,
) -> Capture:
    """Capture ``commands`` (N, m) rad, in this order, into the journal at ``journal_path``.

    Resumes a journal with the same ``header`` (extra JSON-able identity: robot, rig,
    sampler; the commands' hash and the protocol are added here), checking that every
    journaled sample is the command expected at its position. Raises JournalError for a
    journal of other settings; rig errors propagate (the journal keeps every sample
    recorded before them). Returns every sample, old and new.

    ``open_ended``: the command list grows from call to call (active sampling: the next
    batch depends on the samples so far), so the header records no hash of it; each call
    passes the journaled commands followed by the new ones (:func:`journal_samples`
    reads what a journal holds).

    ``protocol.kind == "predictive"`` (:mod:`lab.capture.predictive`): the relaxation is
    ``relaxation`` if given, else the one a resumed journal learned (its ``relaxation``
    note), else learned from the first ``protocol.n_learn`` samples of this session.

    ``repeat_check`` (a fixed list, a waiting protocol): once every command is captured,
    the first is measured again with the same protocol and the journal's ``repeat-check``
    note says whether the tip moved (not a dataset row;
    :func:`~lab.capture.repeat_check.repeat_check_line` reads it).

    Parameters
    ----------
    rig : Rig
        The open rig to capture on.
    commands : array_like
        Commands, shape (N, m), in rad, each checked by the robot's limits before any moves.
    journal_path : str or Path
        The journal (CSV) to create or resume.
    protocol : Protocol
        The capture settings.
    header : dict, optional
        Extra JSON-able identity of the capture (robot, rig, sampler).
    session_info : dict, optional
        Extra JSON-able fields of this session's ``session`` note.
    progress : bool
        Show a progress bar.
    open_ended : bool
        The command list grows from call to call (see above).
    relaxation : Relaxation, optional
        The predictive protocol's relaxation (see above).
    repeat_check : bool
        Measure the first command again after the last (see above).

    Returns
    -------
    Capture
        Every sample in the journal, old and new, in command order.
    """
    from tqdm import tqdm

    from lab.capture.journal import JournalError

    commands = np.asarray(commands, dtype=float)
    m = rig.robot.n_inputs
    if commands.ndim != 2 or commands.shape[1] != m:
        raise InputError(f"commands must have shape (N, {m}), got {commands.shape}")
    for u in commands:
        rig.robot.check_command(u)  # fail before moving anything
    full_header = _full_header(header, protocol, None if open_ended else commands)
    predictive = protocol.kind == "predictive"
    markers = tuple(rig.robot.marker_names)
    if predictive and len(markers) > 1:
        raise InputError(
            f"the predictive protocol watches the tip alone; robot {rig.robot.name!r} has markers "
            f"{', '.join(markers[1:])}: capture it with the waiting protocol"
        )
    cols = journal_columns(m, predictive, markers)
    others = marker_columns(markers)
    with Journal.open(journal_path, full_header, cols) as journal:
        done = len(journal.rows)
        if done > len(commands):
            raise JournalError(f"{journal_path} holds {done} samples, more than the {len(commands)} commands given")
        for i, row in enumerate(journal.rows):
            if int(row["index"]) != i or not np.array_equal([row[f"u{j}"] for j in range(m)], commands[i]):
                raise JournalError(f"{journal_path}: line for sample {i} does not match the command list")
        session = len(journal.notes_tagged("session")) + 1
        journal.note(
            "session",
            {"session": session, "started": _now(), "resumed_at": done, "rig": rig.describe(), **(session_info or {})},
        )
        wall0, status = time.perf_counter(), "complete"
        bar = tqdm(total=len(commands), initial=done, unit="sample", disable=not progress, smoothing=0.05)
        try:
            sample = _sampler(rig, protocol, journal, relaxation)
            for i in range(done, len(commands)):
                s = sample(commands[i])
                journal.append(
                    {
                        "index": i,
                        **{f"u{j}": s.u_motor[j] for j in range(m)},
                        "x": s.p_tip_W[0],
                        "y": s.p_tip_W[1],
                        "z": s.p_tip_W[2],
                        **_other_markers(others, s.markers_W),
                        "settled": int(s.settled),
                        "t_start_s": s.t_start_s,
                        "t_command_s": s.t_command_s,
                        "t_arrived_s": s.t_arrived_s,
                        "t_done_s": s.t_done_s,
                        "n_readings": s.n_readings,
                        "deviation_m": s.deviation_m,
                        "n_frames": s.n_frames,
                        "n_invalid_frames": s.n_invalid_frames,
                        **{f"present_u{j}": s.u_present[j] for j in range(m)},
                        "session": session,
                        **({"pred_std_m": s.pred_std_m, "predicted": int(s.predicted)} if predictive else {}),
                    }
                )
                bar.update(1)
            if repeat_check and not open_ended and protocol.wait and not journal.notes_tagged("repeat-check"):
                # resumed with every sample done: nothing was measured in this session, so the
                # rig is where it started the first sample; the last command goes first
                last = (journal.rows[-1], sample(commands[-1])) if done == len(commands) > 1 else None
                again = sample(commands[0])
                journal.note("repeat-check", repeat_note(journal.rows[0], again, protocol, last))
        except BaseException as err:
            status = f"stopped: {type(err).__name__}: {err}"
            raise
        finally:
            bar.close()
            journal.note(
                "session-end",
                {
                    "session": session,
                    "ended": _now(),
                    "status": status,
                    "new_samples": len(journal.rows) - done,
                    "wall_s": time.perf_counter() - wall0,
                },
            )
        rows, notes = journal.rows, journal.notes
    col = {c: np.array([r[c] for r in rows]) for c in cols}
    return Capture(
        u_motor=np.column_stack([col[f"u{j}"] for j in range(m)]),
        p_tip_W=np.column_stack([col["x"], col["y"], col["z"]]),
        settled=col["settled"].astype(bool),
        sample_s=col["t_done_s"] - col["t_start_s"],
        settle_s=col["t_done_s"] - col["t_command_s"],
        deviation_m=col["deviation_m"],
        n_frames=col["n_frames"].astype(int),
        n_invalid_frames=col["n_invalid_frames"].astype(int),
        session=col["session"].astype(int),
        notes=notes,
        new_samples=len(rows) - done,
        pred_std_m=col["pred_std_m"] if predictive else None,
        predicted=col["predicted"].astype(bool) if predictive else None,
        y_W=np.column_stack([col[c] for c in ["x", "y", "z", *others]]) if others else None,
        markers=markers,
    )


def _other_markers(columns: list[str], markers_W) -> dict:
    """A sample's other markers by journal column (NaN where not seen)."""
    if not columns:
        return {}
    values = np.full(len(columns), np.nan) if markers_W is None else np.asarray(markers_W, float).ravel()[3:]
    return dict(zip(columns, values.tolist()))


def _sampler(rig: Rig, protocol: Protocol, journal, relaxation):
    """``u -> Sample`` for ``protocol``: the waiting protocol's :func:`measure`, or a
    :class:`~lab.capture.predictive.PredictiveSampler` (with the relaxation a resumed journal learned)."""
    if protocol.kind != "predictive":
        return lambda u: measure(rig, u, protocol)
    from lab.capture.predictive import PredictiveSampler
    from lab.dynamics.relaxation import Relaxation

    learned = journal.notes_tagged("relaxation")
    if relaxation is None and learned:
        info = learned[-1]
        relaxation = Relaxation(info["tau_s"], info["weight"], info["noise_sigma_m"], {"from": "journal"})
    return PredictiveSampler(rig, protocol, relaxation, note=journal.note)


def _full_header(header: dict | None, protocol: Protocol, commands: np.ndarray | None) -> dict:
    """The journal's header: ``header``, the protocol and the commands' hash (or, open-ended, none)."""
    listed = {"open_ended": True} if commands is None else {"n": len(commands), "sha256": _sha256(commands)}
    return {"kind": "lab.capture", **(header or {}), "protocol": protocol.as_dict(), "commands": listed}


def journal_samples(
    journal_path, n_motors: int, protocol: Protocol = Protocol(), *, header: dict | None = None, markers=("tip",)
):
    """What an open-ended capture's journal holds; empty if there is no journal.
    Raises JournalError for a journal of other settings (as :func:`capture` would).

    Parameters
    ----------
    journal_path : str or Path
        The journal.
    n_motors : int
        Number of motors m.
    protocol : Protocol
        The capture settings it was written with.
    header : dict, optional
        The extra identity it was written with.
    markers : sequence of str
        The robot's observed points, the tip first (its journal's marker columns).

    Returns
    -------
    u : numpy.ndarray
        Commands, shape (N, m), in rad, in journal order.
    y : numpy.ndarray
        Tips, shape (N, 3), in m in frame W.
    notes : list of tuple
        The journal's notes as (tag, dict).
    """
    from pathlib import Path

    empty = np.empty((0, n_motors)), np.empty((0, 3)), []
    if not Path(journal_path).exists():
        return empty
    cols = journal_columns(n_motors, protocol.kind == "predictive", markers)
    with Journal.open(journal_path, _full_header(header, protocol, None), cols) as journal:
        rows, notes = journal.rows, journal.notes
    if not rows:
        return empty[0], empty[1], notes
    u = np.array([[r[f"u{j}"] for j in range(n_motors)] for r in rows])
    return u, np.array([[r["x"], r["y"], r["z"]] for r in rows]), notes


def _sha256(a: np.ndarray) -> str:
    import hashlib

    return hashlib.sha256(np.ascontiguousarray(a, dtype="<f8").tobytes()).hexdigest()


def _now() -> str:
    import datetime as dt

    return dt.datetime.now(dt.UTC).isoformat(timespec="seconds")
