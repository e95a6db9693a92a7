"""``python -m lab calibrate``: identify the as-built FEM parameters from a real dataset file.

:class:`CalibrationSpec` holds the fit's settings (``--fit`` groups, ``--noise-m``, ``--axes``,
``--max-iter``) and its mesh (:class:`lab.fem.MeshSpec`, ``--n-rings``/``--n-axial``);
:func:`run` checks the dataset against the nominal robot (its robot, its
input columns, its markers: every marker in the data is fitted), runs
:func:`lab.transfer.calibrate` and refuses a fit that did not converge, or whose misfit is
far above what the FEM family can explain
(:func:`misfit_limit_m`); nothing is written then. :func:`calibration_summary` is the
JSON summary the command prints and writes; :func:`discrepancy_line` says in one line
whether the calibrated model explains the samples at the declared noise (the chi-square
test of :func:`lab.transfer.model_check`) and which standard deviations are reported.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from lab.errors import InputError, LabRuntimeError
from lab.fem.bodies.mesh_spec import MeshSpec, mesh_label
from lab.fem.solve.parameter_layout import GROUPS, parse_groups
from lab.specs import Spec, option, positive, positive_int

__all__ = [
    "CalibrationSpec",
    "run",
    "calibration_summary",
    "discrepancy_line",
    "fit_groups",
    "misfit_limit_m",
]

#: A calibrated misfit above this many noise levels is not noise (``--noise-m``: per coordinate).
MISFIT_NOISE_FACTOR = 10.0
#: ... nor above this fraction of the arm's length: what the FEM family cannot explain.
MISFIT_LENGTH_FRACTION = 0.1


def fit_groups(value) -> str | None:
    """The check of :attr:`CalibrationSpec.fit`: None if every group is known, else the problem."""
    try:
        parse_groups(value)
    except InputError as err:
        return f"must be a comma-separated subset of {', '.join(GROUPS)} ({err})"
    return None


@dataclass(frozen=True)
class CalibrationSpec(Spec):
    """How the FEM is fitted to the real samples.

    Parameters
    ----------
    fit : str, optional
        The parameter groups fitted, comma-separated (softness, gradient, eyelets, slack,
        density); None: softness, gradient, eyelets and, with angle-controlled cables, slack.
    noise_m : float
        Tip error per coordinate the fit expects, m (mocap noise plus what the static FEM
        cannot model); weighs the data against the prior.
    axes : str
        Eyelet-shift components identified: "yz" or "xyz".
    max_iter : int
        Levenberg-Marquardt iterations at most.
    mesh : MeshSpec
        The mesh of the FEM fitted (None fields: the description's).
    """

    fit: str | None = option(
        None,
        type=str,
        check=fit_groups,
        help=f"parameter groups fitted, comma-separated: a subset of {', '.join(GROUPS)} (default: softness, "
        "gradient, eyelets and, with angle-controlled cables, slack); density scales the body's mass",
    )
    noise_m: float = option(
        5e-4,
        type=float,
        check=positive,
        unit="m",
        help="tip error per coordinate the fit expects, m: mocap noise plus what the static FEM cannot "
        "model; weighs the data against the prior",
    )
    axes: str = option("yz", choices=("yz", "xyz"), help="eyelet-shift components identified")
    max_iter: int = option(30, type=int, check=positive_int, help="Levenberg-Marquardt iterations at most")
    mesh: MeshSpec = field(default_factory=MeshSpec)


def misfit_limit_m(robot, noise_m: float) -> float:
    """The largest RMS tip misfit (m) a calibrated FEM of ``robot`` may leave:
    ``max(MISFIT_NOISE_FACTOR * noise_m, MISFIT_LENGTH_FRACTION * robot.length_m)``, 20 mm
    for the shipped 0.2 m arm at the default noise.

    Why: the as-built family misfits the nominal FEM by 8-15 mm RMS and calibration takes
    that to 0.1-0.9 mm (docs/results-sim-to-real.md); even the coarsest mesh (1 ring x 6
    layers) fitted to tips simulated on the fine one leaves about 11 mm. Beyond a tenth of
    the arm's length -- or ten times the noise the user declares -- the parameters
    (softness, gradient, eyelet shifts, slack) explain nothing: the data are in other
    units (tips in cm or mm give metres of misfit), another frame, or of another robot.

    Parameters
    ----------
    robot : RobotDescription
        The nominal robot (its ``length_m``).
    noise_m : float
        Declared tip noise per coordinate, m.

    Returns
    -------
    float
        The limit, m.
    """
    return max(MISFIT_NOISE_FACTOR * noise_m, MISFIT_LENGTH_FRACTION * robot.length_m)


def _check_misfit(robot, real, spec: CalibrationSpec, result) -> None:
    """Refuse a fit the FEM family cannot explain: InputError (exit 2) when the misfit
    exceeds twice the arm's length -- farther than any two tips of the arm can be apart, so
    the data are wrong (units, frame) -- else LabRuntimeError (exit 1: the fit failed)."""
    limit = misfit_limit_m(robot, spec.noise_m)
    if result.rms_m <= limit:
        return
    text = (
        f"the calibrated FEM misfits the tips of {real} by {result.rms_m:.4g} m RMS (nominal {result.rms_nominal_m:.4g}"
        f" m), more than the {limit:.3g} m the FEM family can explain; check units (tips in metres), frame W and "
        "--robot; nothing written"
    )
    raise (InputError if result.rms_m > 2 * robot.length_m else LabRuntimeError)(text)


def _iterations_told(log, progress, total: int):
    """A log that also tells ``progress(done, total)`` the iterations of the fit: the
    fitter writes "nominal: ..." before its first iteration and "iteration k: ..." after
    each (:func:`lab.transfer.calibrate.calibrate`)."""
    import re

    def tell(line: str) -> None:
        m = re.match(r"(?:nominal|iteration (\d+)):", line)
        if m:
            progress(int(m.group(1) or 0), total)
        if log is not None:
            log(line)

    return tell


def run(spec: CalibrationSpec, robot, real, *, log=None, progress=None):
    """Calibrate ``robot`` on the dataset file ``real``.

    Parameters
    ----------
    spec : CalibrationSpec
        The fit's settings and mesh.
    robot : RobotDescription
        The nominal robot (:class:`lab.description.RobotDescription`).
    real : str or Path
        Real dataset CSV (``u0..,x,y,z``; metres) with its sidecar.
    log : callable, optional
        Called with each progress line.
    progress : callable, optional
        ``progress(done, total)``: Levenberg-Marquardt iterations done of at most ``total``
        (``spec.max_iter``; the fit may converge sooner), 0 as the first starts.

    Returns
    -------
    CalibrationResult
        The converged :class:`lab.transfer.CalibrationResult`. InputError for data of another
        robot or the wrong number of motors, LabRuntimeError if not converged; a misfit above
        :func:`misfit_limit_m` is refused too (InputError beyond twice the arm's length: data
        in other units or frame; else LabRuntimeError).
    """
    from lab.data.dataset import dataset_markers, read_dataset
    from lab.transfer.calibrate import calibrate, default_groups

    n_rings, n_axial = spec.mesh.resolve(robot)
    groups = default_groups(robot) if spec.fit is None else parse_groups(spec.fit)
    if "slack" in groups and all(c.control == "tension" for c in robot.cables):
        raise InputError(
            f"--fit slack: {robot.name} has no angle-controlled cable (slack is a spool cable's free length; a "
            "tendon held at a tension takes up its slack); fit softness, gradient, eyelets or density"
        )
    u, y, meta = read_dataset(real)
    name = (meta.get("robot") or {}).get("name")
    if name is not None and name != robot.name:
        raise InputError(f"REAL.csv {real} was captured on robot {name!r}, but the robot calibrated is {robot.name!r}")
    if u.shape[1] != robot.n_inputs:
        raise InputError(f"{real}: {u.shape[1]} input columns, but {robot.name} has {robot.n_inputs} inputs")
    markers = dataset_markers(meta, y, robot, str(real))
    if log is not None:
        log(
            f"{robot.name}: calibrating {', '.join(groups)} on {len(u)} real samples of {', '.join(markers)} from "
            f"{real}, mesh {mesh_label(robot, n_rings, n_axial)}"
            + (f", eyelet shifts in {spec.axes}" if "eyelets" in groups else "")
        )
    if progress is not None:
        log = _iterations_told(log, progress, spec.max_iter)
    try:
        result = calibrate(robot, u, y, n_rings=n_rings, n_axial=n_axial, axes=spec.axes, noise_m=spec.noise_m,
                           max_iter=spec.max_iter, log=log, groups=groups, markers=markers)  # fmt: skip
    except InputError as err:
        raise InputError(f"{real}: {err}") from None
    _check_misfit(robot, real, spec, result)
    if not result.converged:
        raise LabRuntimeError(
            f"calibration did not converge in {result.iterations} iterations (RMS tip misfit "
            f"{1e3 * result.rms_m:.3f} mm); nothing written: raise CalibrationSpec.max_iter, or check the data"
        )
    return result


def calibration_summary(robot, result, real, out, command: str) -> dict:
    """The JSON summary (kind ``lab.calibration``) of ``result`` for ``robot``.

    Parameters
    ----------
    robot : RobotDescription
        The nominal robot.
    result : CalibrationResult
        What :func:`run` returned.
    real : str or Path
        The real dataset file.
    out : str or Path
        The calibrated robot's TOML.
    command : str
        The command line.

    Returns
    -------
    dict
        The summary: robot, files, the result's :meth:`~lab.transfer.CalibrationResult.summary`,
        command and code version.
    """
    from lab.files import code_version

    return {
        "kind": "lab.calibration",
        "format_version": 1,
        "robot": robot.name,
        "real": str(real),
        "out": str(out),
        **result.summary(),
        "command": command,
        "code_version": code_version(),
    }


def discrepancy_line(result) -> str:
    """One line on the chi-square test of ``result`` (a :class:`lab.transfer.CalibrationResult`):
    whether the calibrated model explains the samples at the declared noise, the RMS 3-D
    residual against the RMS a correct model leaves, and the standard deviations reported.

    Parameters
    ----------
    result : CalibrationResult
        What :func:`run` returned.

    Returns
    -------
    str
        The line.
    """
    c = result.check
    mm = f"residual {1e3 * c['rms_m']:.3f} mm RMS against {1e3 * c['expected_rms_m']:.3f} mm expected from the noise"
    stat = (
        f"(--noise-m {1e3 * c['noise_m']:.3g} mm per coordinate; chi-square {c['chi2']:.1f} on {c['dof']:.1f} "
        f"degrees of freedom, reduced {c['reduced_chi2']:.2f}"
    )
    stds = (
        f"standard deviations inflated by the Birge ratio {c['std_inflation']:.2f}"
        if c["std_inflation"] > 1
        else "standard deviations at the declared noise"
    )
    if not c["model_discrepancy"]:
        return f"the calibrated model explains these samples: {mm} {stat}); {stds}"
    return (
        f"the calibrated model does not explain these samples: {mm} {stat}, above its {c['quantile']:g} "
        f"quantile {c['chi2_threshold']:.1f}); {stds}, but model error the FEM has no parameter for (a tilted "
        "base, the mocap frame, stretching cables, another foam law) biases the parameters beyond any std"
    )
