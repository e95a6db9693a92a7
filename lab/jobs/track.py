"""``python -m lab track``: one run from its settings, :class:`TrackSpec` and :func:`run`.

The command line (:mod:`lab.cli.track`) is a thin shell over this module: it turns its flags into one
:class:`TrackSpec` -- the trajectory and the mode (open loop, closed loop, or streamed at a
period), with the rig (:class:`lab.rig.RigSpec`), the FEM mesh (:class:`lab.fem.MeshSpec`),
the IK (:class:`lab.control.IKConfig`), the correction (:class:`lab.tracking.closed_loop.Correction`)
and the streaming settings (:class:`lab.tracking.stream_spec.StreamSpec`) -- and :func:`run` does
the rest: robot, trajectory, models, IK, rig, the run, the result file. A settled run keeps
each measured point in ``OUT.points.csv`` (:mod:`lab.tracking.points`) until the result is written. With
``--rig none`` there is no rig: :func:`lab.tracking.offline.run_offline` writes the IK's
commands for a lab's own robot. Every count and duration is bounded, so a run always ends.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from lab.control.ik import IKConfig, IKSolver
from lab.control.trajectories import BUILTIN, SIX_CABLE, load_trajectory
from lab.description import load_robot
from lab.dynamics.relaxation import load_relaxation
from lab.errors import FieldError
from lab.fem.bodies.mesh_spec import MeshSpec
from lab.fem.model import ArmFEM
from lab.learn.models import load_model
from lab.rig import RigSpec, make_rig
from lab.rig.spec import RIG
from lab.specs import Spec, at_most, option, positive, positive_int
from lab.tracking.closed_loop import MODES, Correction, check_passes, run_closed_loop
from lab.tracking.marker_targets import with_marker_offsets
from lab.tracking.offline import run_offline
from lab.tracking.points import PointLog
from lab.tracking.stream import stream_trajectory
from lab.tracking.stream_spec import StreamSpec
from lab.tracking.track import TrackResult, run_trajectory, write_result

__all__ = ["TrackSpec", "run", "MAX_POINTS", "MAX_MEASUREMENTS", "NO_RIG_UNUSED"]

#: The most targets of a trajectory (a built-in's ``n_points`` or a CSV's rows).
MAX_POINTS = 10_000
#: The most settled measurements of one run (targets x passes): about a day on hardware.
MAX_MEASUREMENTS = 100_000
_NESTED = {"rig": RigSpec, "mesh": MeshSpec, "ik": IKConfig, "correction": Correction}
#: The robot and noise seed of a run that names none.
DEFAULT_ROBOT, DEFAULT_SEED = "three-cable", 0
#: What a run without a rig (``RigSpec.rig`` none) does not use, and why: (the settings, as
#: ``Class.field``; the reason). :meth:`TrackSpec.__post_init__` refuses them; the command
#: line refuses their flags with the same words.
NO_RIG_UNUSED = (
    (
        ("TrackSpec.soft_ik",),
        f"Soft IK solves through the FEM of a shipped robot; {RIG} none solves through TrackSpec.model",
    ),
    (
        ("TrackSpec.closed_loop", "TrackSpec.passes", "Correction.gain"),
        "a closed loop corrects from measured tips, and nothing is measured",
    ),
    (
        (
            "TrackSpec.stream",
            "TrackSpec.dynamic_model",
            "StreamSpec.n_periods",
            "StreamSpec.lead_in_s",
            "StreamSpec.command_rate_hz",
        ),
        f"streaming times the commands on a rig; {RIG} none writes them to OUT.commands.csv",
    ),
    (("TrackSpec.seed",), "it seeds an emulated rig's noise"),
    (("MeshSpec.n_rings", "MeshSpec.n_axial"), "they set an FEM mesh, and no FEM is used"),
    (
        ("TrackSpec.robot",),
        "the commands are kept in the box of the model's training data, and a model trained on a "
        "shipped robot's data brings that robot's limits",
    ),
)


@dataclass(frozen=True)
class TrackSpec(Spec):
    """Everything one ``track`` run needs (module docstring). A ``none`` rig takes a model
    and nothing about a rig (no robot, seed, mesh, closed loop or stream).

    Parameters
    ----------
    trajectory : str
        A built-in trajectory's name or a CSV file of targets (header x,y,z; metres, frame W).
    n_points : int, optional
        Points of a built-in trajectory (None: its own); at most :data:`MAX_POINTS`.
    closed_loop : str, optional
        None (open loop), "ilc" or "feedback", with ``passes`` and ``correction``.
    passes : int
        Closed loop: runs including the open-loop pass 0 (ilc), or measurements per target (feedback).
    dynamic_model : str, optional
        Streamed: a ``fit-dynamics`` file (.npz) inverted into a feed-forward pre-compensation.
    model : str, optional
        A learned forward model (.npz); None for Soft IK through the FEM.
    robot : str, optional
        Shipped robot name or description TOML; None for :data:`DEFAULT_ROBOT`.
    seed : int, optional
        Noise seed of an emulated rig; None for :data:`DEFAULT_SEED`.
    rig : RigSpec
        The rig (``sim``, a twin, hardware, or ``none``).
    mesh : MeshSpec
        The FEM of ``--rig sim`` and Soft IK (and of an emulated twin when streamed).
    ik : IKConfig
        The IK's settings.
    correction : Correction
        The closed loop's correction.
    stream : StreamSpec, optional
        Streamed at a period: its settings; None for a settled run.
    max_spread_mm : float, optional
        The IK's uncertainty threshold (mm); it sets ``ik.max_spread_m``.

    A ``none`` rig takes nothing of :data:`NO_RIG_UNUSED`; each rule raises a
    :class:`lab.errors.FieldError` naming its fields.
    """

    trajectory: str | None = option(
        None,
        required=True,
        help="circle, square, rose, helix (three-cable), six-circle, six-ring, six-saddle, six-spiral "
        "(six-cable), or a CSV file with header x,y,z (metres, frame W)",
    )
    n_points: int | None = option(
        None,
        type=int,
        check=at_most(MAX_POINTS, positive_int),
        help="points of a built-in trajectory (default: its own)",
    )
    closed_loop: str | None = option(
        None,
        choices=MODES,
        help="correct the commands from the measured tip through the model's Jacobian: ilc = iterative "
        "learning control over repeated passes of the whole trajectory; feedback = settle, measure, "
        "correct at each target (default: open loop)",
    )
    passes: int = option(
        3,
        type=int,
        check=check_passes,
        help="with --closed-loop: runs including the open-loop pass 0 (ilc), or measurements per target (feedback)",
    )
    dynamic_model: str | None = option(
        None,
        help="with --period-s: the dynamic model DYN.npz of `fit-dynamics`, inverted into a feed-forward "
        "pre-compensation of the commands (default: quasi-static open loop)",
    )
    max_spread_mm: float | None = option(
        None,
        check=positive,
        unit="mm",
        help="flag a target 'uncertain' where the model's predicted spread exceeds this, mm "
        "(default 1 mm for a model with a spread; never for one without)",
    )
    model: str | None = option(None, cli=False, help="learned forward model (.npz); None: Soft IK through the FEM")
    robot: str | None = option(
        None, cli=False, help="shipped robot name or path to a TOML description (default three-cable)"
    )
    seed: int | None = option(None, cli=False, help="noise seed of an emulated rig (default 0)")
    rig: RigSpec = option(RigSpec(), cli=False, help="the rig")
    mesh: MeshSpec = option(MeshSpec(), cli=False, help="the FEM mesh")
    ik: IKConfig = option(IKConfig.automatic(), cli=False, help="the IK's settings")
    correction: Correction = option(Correction(), cli=False, help="the closed loop's correction")
    stream: StreamSpec | None = option(None, cli=False, help="streamed at a period: its settings")

    def __post_init__(self):
        super().__post_init__()
        for name, cls in _NESTED.items():
            if not isinstance(getattr(self, name), cls):
                raise self.field_error(
                    f"{self.name_of(name)} must be a {cls.__name__}, got {getattr(self, name)!r}", name
                )
        if self.stream is not None and not isinstance(self.stream, StreamSpec):
            raise self.field_error(
                f"{self.name_of('stream')} must be a StreamSpec or None, got {self.stream!r}", "stream"
            )
        if self.max_spread_mm is not None:  # the spread in mm, the IK's threshold in m
            object.__setattr__(self, "ik", self.ik.replace(max_spread_m=1e-3 * self.max_spread_mm))
        name = self.name_of
        if self.stream is not None and self.closed_loop is not None:
            raise self.field_error(
                f"{name('stream')} streams open loop or feed-forward; it does not combine with {name('closed_loop')}",
                "stream",
                "closed_loop",
            )
        if self.dynamic_model is not None and self.stream is None:
            raise self.field_error(f"{name('dynamic_model')} needs {name('stream')} T", "dynamic_model", "stream")
        if self.ik.markers != ("tip",) and (self.stream is not None or self.closed_loop is not None):
            used = "stream" if self.stream is not None else "closed_loop"
            raise self.field_error(
                f"IKConfig.markers {','.join(self.ik.markers)}: a "
                f"{name(used)} run corrects or times the tip alone; drive markers other than the tip open loop",
                "IKConfig.markers",
                used,
            )
        if not self.rig.has_rig:
            self._check_no_rig()
        fem_rigs = ("sim", "twin") if self.stream is not None else ("sim",)
        if not self.mesh.is_default and self.rig.kind not in fem_rigs and not self.soft_ik:
            where = f"{RIG} sim, an emulated twin" if self.stream is not None else f"{RIG} sim"
            raise self.field_error(
                f"MeshSpec.n_rings/MeshSpec.n_axial set the FEM mesh of {where} and {name('soft_ik')} only",
                "MeshSpec.n_rings",
                "MeshSpec.n_axial",
                RIG,
                "soft_ik",
            )

    def _check_no_rig(self) -> None:
        """FieldError for a setting a run without a rig has no use for (:data:`NO_RIG_UNUSED`)."""
        stream = self.stream or StreamSpec(period_s=1.0)
        given = {
            "TrackSpec.soft_ik": self.soft_ik,
            "TrackSpec.closed_loop": self.closed_loop is not None,
            "Correction.gain": self.correction != Correction(),
            "TrackSpec.stream": self.stream is not None,
            "TrackSpec.dynamic_model": self.dynamic_model is not None,
            "StreamSpec.n_periods": stream.n_periods is not None,
            "TrackSpec.seed": self.seed is not None,
            "MeshSpec.n_rings": self.mesh.n_rings is not None,
            "MeshSpec.n_axial": self.mesh.n_axial is not None,
            "TrackSpec.robot": self.robot is not None,
        }
        for names, why in NO_RIG_UNUSED:
            if used := [n for n in names if given.get(n)]:
                verb = "is" if len(used) == 1 else "are"
                raise FieldError(f"{', '.join(used)} {verb} not used with {RIG} none ({why})", *used, RIG)

    @property
    def soft_ik(self) -> bool:
        """Whether the IK solves through the FEM (no learned model)."""
        return self.model is None

    @property
    def mode(self) -> str:
        """The mode: "open-loop", "ilc", "feedback" or "streamed"."""
        return "streamed" if self.stream is not None else self.closed_loop or "open-loop"


def run(spec: TrackSpec, out: str | Path, *, command: str | None = None, say: Callable | None = None):
    """Run ``spec`` and write its result file (JSON, docs/design/tracking.md) to ``out``.

    Parameters
    ----------
    spec : TrackSpec
        The run's settings.
    out : str or Path
        The result file; a settled run keeps its points in ``OUT.points.csv`` meanwhile.
    command : str, optional
        The command line, recorded as ``info.command``.
    say : callable, optional
        Called with each line the user should read (IK notes, the points kept when the run
        stops); default silent.

    Returns
    -------
    TrackResult or StreamResult or SolvedTargets
        The :class:`~lab.tracking.track.TrackResult` (a ``StreamResult`` when streamed, a
        :class:`~lab.tracking.solved_targets.SolvedTargets` with ``--rig none``: the result file and
        ``OUT.commands.csv``, nothing measured). Raises InputError for bad settings or
        inputs, before the rig is made; a rig's failure (exit 1) or an interrupt after the
        rig was closed, with the measured points kept.
    """
    say = say or (lambda line: None)
    if not spec.rig.has_rig:
        return run_offline(spec, out, command=command, say=say, max_points=MAX_POINTS)
    robot = load_robot(spec.robot or DEFAULT_ROBOT)
    log = None if spec.stream is not None else PointLog(f"{out}.points.csv", robot.n_inputs)
    targets = load_trajectory(spec.trajectory, spec.n_points)
    _check_size(spec, len(targets))
    relax = None if spec.dynamic_model is None else load_relaxation(spec.dynamic_model)
    fem = ArmFEM(robot, **spec.mesh.overrides()) if (spec.rig.kind == "sim" or spec.soft_ik) else None
    model = None if spec.soft_ik else load_model(spec.model)
    solver = IKSolver.for_model(model, robot, spec.ik, fem=fem if spec.soft_ik else None)
    solver = with_marker_offsets(solver, model, fem)
    for note in solver.notes:
        say(f"IK: {note}")
    name = spec.trajectory if spec.trajectory in BUILTIN + SIX_CABLE else Path(spec.trajectory).name
    sim, twin = spec.rig.kind == "sim", spec.rig.kind == "twin"
    try:
        with make_rig(
            spec.rig, robot, seed=spec.seed or DEFAULT_SEED, fem=fem if sim else None, mesh=spec.mesh if twin else None
        ) as rig:
            result = _follow(spec, rig, solver, targets, name, relax, log)
    except BaseException:
        if log is not None:
            log.close()
            if note := log.note():
                say(note)
        raise
    if log is not None:
        log.close()
    streamed = {} if spec.stream is None else {"dynamic_model_path": spec.dynamic_model}
    write_result(out, result, {"model": spec.model, "soft_ik": spec.soft_ik, **streamed, "command": command})
    if log is not None:
        log.remove()  # the result file holds a complete run now
    return result


def _check_size(spec: TrackSpec, n_targets: int) -> None:
    """Refuse a trajectory, or a closed loop over it, longer than a run may be."""
    if n_targets > MAX_POINTS:
        message = f"{spec.name_of('trajectory')} {spec.trajectory}: {n_targets} points, at most {MAX_POINTS}"
        raise spec.field_error(message, "trajectory")
    passes = spec.passes if spec.closed_loop is not None else 1
    if n_targets * passes > MAX_MEASUREMENTS:
        raise spec.field_error(
            f"{spec.name_of('passes')} {passes} over {n_targets} points is {n_targets * passes} measurements: "
            f"at most {MAX_MEASUREMENTS} in one run",
            "passes",
        )


def _follow(spec: TrackSpec, rig, solver, targets, name: str, relax, log: PointLog | None) -> TrackResult:
    """The run itself on the open ``rig``: streamed, open loop or closed loop."""
    if spec.stream is not None:
        s = spec.stream
        return stream_trajectory(
            rig, solver, targets, s.period_s, relax=relax, n_periods=s.n_periods, command_rate_hz=s.command_rate_hz,
            lead_in_s=s.lead_in_s, smoothing=s.smoothing, name=name,
        )  # fmt: skip
    if spec.closed_loop is None:
        return run_trajectory(rig, solver, targets, name=name, on_point=log.append)
    return run_closed_loop(
        rig, solver, targets, mode=spec.closed_loop, passes=spec.passes, correction=spec.correction, name=name,
        on_point=log.append,
    )  # fmt: skip
