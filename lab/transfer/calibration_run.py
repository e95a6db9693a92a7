"""The ``calibrate`` run: identify the as-built FEM parameters from a real dataset file.

:class:`CalibrationSpec` holds the fit's settings (``--noise-m``, ``--axes``,
``--max-iter``) and its mesh (:class:`lab.fem.MeshSpec`, ``--n-rings``/``--n-axial``);
:func:`calibration_run` checks the dataset against the nominal robot (its robot, its
motor columns), runs :func:`lab.transfer.calibrate` and refuses a fit that did not
converge (LabRuntimeError: nothing is written). :func:`calibration_summary` is the JSON
summary the command prints and writes.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from lab.errors import InputError, LabRuntimeError
from lab.fem.mesh_spec import MeshSpec
from lab.specs import Spec, option, positive, positive_int

__all__ = ["CalibrationSpec", "calibration_run", "calibration_summary"]


@dataclass(frozen=True)
class CalibrationSpec(Spec):
    """How the FEM is fitted to the real samples."""

    noise_m: float = option(
        5e-4,
        type=float,
        check=positive,
        help="tip error per coordinate the fit expects, m: mocap noise plus what the static FEM cannot "
        "model; weighs the data against the prior",
    )
    axes: str = option("yz", choices=("yz", "xyz"), help="eyelet-shift components identified")
    max_iter: int = option(30, type=int, check=positive_int, help="Levenberg-Marquardt iterations at most")
    mesh: MeshSpec = field(default_factory=MeshSpec)


def calibration_run(robot, real, spec: CalibrationSpec, *, log=None):
    """Calibrate ``robot`` (a :class:`lab.description.RobotDescription`) on the dataset file
    ``real``; returns the converged :class:`lab.transfer.CalibrationResult`. InputError for
    data of another robot or the wrong number of motors, LabRuntimeError if not converged."""
    from lab.data.dataset import read_dataset
    from lab.transfer.calibrate import calibrate

    n_rings, n_axial = spec.mesh.resolve(robot)
    u, y, meta = read_dataset(real)
    name = (meta.get("robot") or {}).get("name")
    if name is not None and name != robot.name:
        raise InputError(f"REAL.csv {real} was captured on robot {name!r}, but --robot is {robot.name!r}")
    if u.shape[1] != robot.n_cables:
        raise InputError(f"{real}: {u.shape[1]} motor columns, but {robot.name} has {robot.n_cables} cables")
    if log is not None:
        log(
            f"{robot.name}: calibrating on {len(u)} real samples from {real}, mesh n_rings={n_rings} "
            f"n_axial={n_axial}, eyelet shifts in {spec.axes}"
        )
    try:
        result = calibrate(robot, u, y, n_rings=n_rings, n_axial=n_axial, axes=spec.axes, noise_m=spec.noise_m,
                           max_iter=spec.max_iter, log=log)  # fmt: skip
    except InputError as err:
        raise InputError(f"{real}: {err}") from None
    if not result.converged:
        raise LabRuntimeError(
            f"calibration did not converge in {result.iterations} iterations (RMS tip misfit "
            f"{1e3 * result.rms_m:.3f} mm); nothing written: raise --max-iter, or check the data"
        )
    return result


def calibration_summary(robot, result, real, out, command: str) -> dict:
    """The JSON summary (kind ``lab.calibration``) of ``result`` for ``robot``."""
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
