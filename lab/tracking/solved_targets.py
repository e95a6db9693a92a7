"""What ``track --rig none`` reports: :class:`SolvedTargets`, its result file and ``OUT.commands.csv``.

Nothing is measured without a rig, so the report says what the model knows and no more:

* the **IK residual through the model**, ``|f(u) - target|`` (m): how closely the model's
  tip at the answer meets the target, i.e. how well the IK inverted the model. It is not an
  accuracy: how far the robot's tip will land from the target is the model's own error at
  ``u``, which only a measurement shows (a rig run, or the held-out errors of ``train`` and
  the repeatability floor of ``inspect``). A reached target's residual is below the IK's
  ``reach_tol_m`` (10 um), so it is near zero by construction;
* the **uncertainty**: the model's spread at each answer (an ensemble's spread across its
  members, or a Gaussian process's posterior standard deviation); a single network gives
  no uncertainty estimate, and says so;
* the **largest command step** between neighbouring targets, in the commands' units and as
  a fraction of the box the commands were kept in (a jump across the box would be a motor
  sweeping its whole range between two close targets).

The result file's keys written before these words were chosen stay, as files already
written and the scripts reading them use them: ``predicted_error_m`` and its mean and max
are the IK residual (``ik_residual_m`` and its mean and max, the same numbers), and the
column ``error_m`` of ``OUT.commands.csv`` is too. ``OUT.commands.csv`` is the result
file's name with ``.commands.csv`` appended (``plan.json`` -> ``plan.json.commands.csv``,
as ``OUT.lock`` and a rig run's ``OUT.points.csv``); :func:`check_commands_file` refuses,
before any work, a file of that name this program did not write. The keys are listed in
docs/design/tracking.md ("Commands without a rig").
"""

from __future__ import annotations

import csv
import io
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from lab.errors import InputError

__all__ = ["SolvedTargets", "commands_path", "check_commands_file", "command_steps", "spread_source", "KIND",
           "JUMP_FRACTION"]  # fmt: skip

FORMAT_VERSION = 1
KIND = "lab.track.commands"
#: The first line of every ``OUT.commands.csv`` this program writes, for any number of motors.
#: A step between neighbouring targets' commands larger than this fraction of a motor's range
#: in the box is a jump the summary names: where the model reaches a target only from another
#: branch of commands than the one before (a model of measured data can have such branches
#: that end inside the box; docs/design/ik.md, smooth paths).
JUMP_FRACTION = 0.25
#: The first line of every ``OUT.commands.csv`` this program writes, for any number of motors.
COMMANDS_HEADER = re.compile(r"u0(,u[1-9][0-9]*)*,x_pred,y_pred,z_pred,error_m(,spread_m)?")


def commands_path(out) -> str:
    """The commands file of the result file ``out``: its name with ``.commands.csv`` appended.

    Parameters
    ----------
    out : str or Path
        The result JSON file.

    Returns
    -------
    str
        ``OUT.commands.csv`` (``plan.json`` -> ``plan.json.commands.csv``).
    """
    return f"{out}.commands.csv"


def check_commands_file(path) -> None:
    """InputError (nothing changed) if ``path`` exists and is not a commands file this
    program wrote (a directory, or a file whose first line is not a commands header); an
    earlier run's file is overwritten by the next result.

    Parameters
    ----------
    path : str or Path
        The commands file, ``OUT.commands.csv``.
    """
    p = Path(path)
    if not p.exists() and not p.is_symlink():
        return
    if not p.is_file():
        raise InputError(f"commands file {p} exists and is not a file; nothing was changed: move it away or choose "
                         "another result file")  # fmt: skip
    with open(p, "rb") as fh:
        first = fh.readline(4096).rstrip(b"\r\n").decode("utf-8", "replace")
    if not COMMANDS_HEADER.fullmatch(first):
        raise InputError(
            f"commands file {p} exists and is not one this program wrote (its first line is not the header "
            "u0..u{m-1},x_pred,y_pred,z_pred,error_m); nothing was changed: move it away or choose another "
            "result file"
        )


def command_steps(commands, u_min, u_max) -> dict:
    """The largest change of a command between neighbouring targets.

    Parameters
    ----------
    commands : array_like
        The answers (N, m), in the commands' units.
    u_min, u_max : array_like
        The box (m,) the commands were kept in, same units.

    Returns
    -------
    dict
        ``max`` (the largest change of any motor, commands' units), ``max_fraction_of_box``
        (the largest change of a motor over its range in the box, dimensionless), ``at``
        (the target, 0-based, whose command is that fraction away from the one before;
        None values for fewer than two targets) and ``jumps`` (the targets whose command is
        more than :data:`JUMP_FRACTION` of the box away from the one before, a list).
    """
    u = np.asarray(commands, dtype=float)
    if len(u) < 2:
        return {"max": None, "max_fraction_of_box": None, "at": None, "jumps": []}
    step = np.abs(np.diff(u, axis=0))
    fraction = step / (np.asarray(u_max, dtype=float) - np.asarray(u_min, dtype=float))
    return {
        "max": float(step.max()),
        "max_fraction_of_box": float(fraction.max()),
        "at": int(np.argmax(fraction.max(axis=1))) + 1,
        "jumps": [int(i) + 1 for i in np.flatnonzero(fraction.max(axis=1) > JUMP_FRACTION)],
    }


def spread_source(model) -> str | None:
    """Where a model's spread comes from, in words (the result's ``uncertainty.source``).

    Parameters
    ----------
    model : object
        The forward model.

    Returns
    -------
    str or None
        "ensemble spread (K members)", "the model's predicted standard deviation" (e.g. a
        Gaussian process), or None for a model without a spread.
    """
    members = getattr(model, "members", None)
    if members is not None and len(list(members)) >= 2:
        return f"ensemble spread ({len(list(members))} members)"
    if callable(getattr(model, "predict_with_std", None)):
        return "the model's predicted standard deviation"
    return None


@dataclass
class SolvedTargets:
    """The IK's answers for N targets without a rig.

    Attributes
    ----------
    trajectory : str
        The trajectory's name.
    targets_W, predicted_W : numpy.ndarray
        Targets and the model's tips at the answers, shape (N, 3), m.
    commands : numpy.ndarray
        The IK's answers, shape (N, m), in the training data's units (rad for a shipped robot).
    reachable, uncertain : numpy.ndarray
        Per target, shape (N,), bool.
    spread_m : numpy.ndarray
        The model's spread at each answer, shape (N,), m (NaN without a spread).
    iterations : numpy.ndarray
        IK iterations per target, shape (N,), int.
    history : int
        The model's history length K (0: none).
    u_min, u_max : numpy.ndarray
        The box the commands were kept in, shape (m,).
    has_spread : bool
        Whether the model has a spread.
    timings : dict
        Wall times, s.
    info : dict
        Model, robot, the IK's settings and what it did; ``uncertainty_source``: where the
        spread comes from, in words (None without one).
    """

    trajectory: str
    targets_W: np.ndarray
    commands: np.ndarray
    predicted_W: np.ndarray
    reachable: np.ndarray
    uncertain: np.ndarray
    spread_m: np.ndarray
    iterations: np.ndarray
    history: int
    u_min: np.ndarray
    u_max: np.ndarray
    has_spread: bool
    timings: dict
    info: dict

    @property
    def ik_residuals_m(self) -> np.ndarray:
        """The IK residual through the model, |f(u) - target| (N,) m (module docstring)."""
        return np.linalg.norm(self.predicted_W - self.targets_W, axis=1)

    @property
    def errors_m(self) -> np.ndarray:
        """:attr:`ik_residuals_m` under its earlier name (the result file's ``predicted_error_m``)."""
        return self.ik_residuals_m

    def to_json(self) -> dict:
        """The JSON document of the result file (docs/design/tracking.md).

        Returns
        -------
        dict
            The document (kind ``lab.track.commands``), arrays as numpy arrays (m, s).
        """
        r = self.ik_residuals_m
        spread = self.spread_m[np.isfinite(self.spread_m)] if self.has_spread else np.zeros(0)
        return {
            "format_version": FORMAT_VERSION,
            "kind": KIND,
            "rig": "none",
            "trajectory": self.trajectory,
            "units": {
                "positions": "m",
                "commands": self.info.get("command_unit"),
                "errors": "m",
                "residuals": "m",
                "timings": "s",
            },  # fmt: skip
            "targets": self.targets_W,
            "commands": self.commands,
            "predicted": self.predicted_W,
            "ik_residual_m": r,
            "mean_ik_residual_m": float(np.mean(r)),
            "max_ik_residual_m": float(np.max(r)),
            "predicted_error_m": r,
            "mean_predicted_error_m": float(np.mean(r)),
            "max_predicted_error_m": float(np.max(r)),
            "reachable": self.reachable,
            "n_unreachable": int(np.sum(~self.reachable)),
            "uncertainty": {
                "source": self.info.get("uncertainty_source"),
                "mean_spread_m": float(np.mean(spread)) if len(spread) else None,
                "max_spread_m": float(np.max(spread)) if len(spread) else None,
            },
            "uncertain": self.uncertain,
            "n_uncertain": int(np.sum(self.uncertain)),
            "predicted_spread_m": self.spread_m,
            "command_steps": command_steps(self.commands, self.u_min, self.u_max),
            "ik_iterations": self.iterations,
            "history": self.history,
            "command_bounds": {"u_min": self.u_min, "u_max": self.u_max},
            "timings": self.timings,
            "info": self.info,
        }

    def commands_csv(self) -> str:
        """``OUT.commands.csv``: ``u0..u{m-1},x_pred,y_pred,z_pred,error_m`` (``error_m``: the
        IK residual) and ``spread_m`` for a model with a spread, one row per target in order.

        Returns
        -------
        str
            The CSV text, floats written with ``repr``.
        """
        m = self.commands.shape[1]
        cols = [self.commands, self.predicted_W, self.ik_residuals_m[:, None]]
        header = [f"u{j}" for j in range(m)] + ["x_pred", "y_pred", "z_pred", "error_m"]
        if self.has_spread:
            cols.append(self.spread_m[:, None])
            header.append("spread_m")
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow(header)
        writer.writerows([[repr(float(v)) for v in row] for row in np.hstack(cols)])
        return buf.getvalue()

    def summary(self, out) -> list[str]:
        """What the run did, in a few lines for the terminal.

        Parameters
        ----------
        out : str or Path
            The result file, named in the lines.

        Returns
        -------
        list of str
            The lines (residuals and spreads in mm, IK time in ms).
        """
        r = self.ik_residuals_m
        past = f" (history {self.history}: each target's past is the answers before it)" if self.history else ""
        doc = self.to_json()
        u = doc["uncertainty"]
        if u["source"] is None:
            known = "no uncertainty estimate (this model gives no spread; an ensemble would)"
        elif u["mean_spread_m"] is None:
            known = f"uncertainty: {u['source']}, not finite at any answer"
        else:
            known = (
                f"uncertainty: {u['source']} mean {1e3 * u['mean_spread_m']:.3g} mm, max "
                f"{1e3 * u['max_spread_m']:.3g} mm, {doc['n_uncertain']} uncertain (over "
                f"{1e3 * self.info['solver']['max_spread_m']:.3g} mm)"
            )
        steps, unit = doc["command_steps"], self.info.get("command_unit")
        step = "" if steps["max"] is None else (
            f"; largest command step between neighbouring targets {steps['max']:.3g}"
            f"{' rad' if unit == 'rad' else ''} ({100 * steps['max_fraction_of_box']:.3g}% of the box, "
            f"at target {steps['at']})"
        )  # fmt: skip
        jumps = steps["jumps"]
        jumped = [] if not jumps else [
            f"the commands jump by more than {100 * JUMP_FRACTION:g}% of the box at {len(jumps)} target(s) "
            f"({', '.join(map(str, jumps[:10]))}{', ...' if len(jumps) > 10 else ''}): the model reaches each of "
            "them only from commands far from the target before's (the answers near those end at the box); a robot "
            "sent them moves fast in between"
        ]  # fmt: skip
        return [
            f"{self.trajectory}: {len(r)} targets solved through the model, no rig{past}: nothing is measured, so "
            f"this says how well the IK inverted the model, not where the robot's tip will be",
            f"IK residual through the model (its tip at the commands against the targets): mean "
            f"{1e3 * np.mean(r):.3g} mm, max {1e3 * np.max(r):.3g} mm, {int(np.sum(~self.reachable))} "
            f"unreachable; {known}",
            f"IK ({self.info['solver']['method']}) {1e3 * self.timings['ik_per_target_mean_s']:.2f} ms per "
            f"target{step} -> {out}, commands -> {commands_path(out)}",
            *jumped,
        ]
