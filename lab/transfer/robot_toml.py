"""A calibrated robot as a robot description TOML, in the format of ``lab/robots/*.toml``.

:func:`calibrated_robot` turns a :class:`~lab.transfer.calibrate.CalibrationResult` into a
:class:`~lab.description.RobotDescription` that every command accepts as ``--robot``:
the nominal description with the identified modulus (s E), the optional
``material.stiffness_gradient`` and ``cables[].slack_m`` fields, and every eyelet moved
(each cable's anchor written out, so it stays where it was). Its ``[mesh]`` is the mesh the
parameters were identified on: they absorb that mesh's discretisation error, so the FEM
of the file reproduces the calibrated FEM exactly. The identified parameters, their
standard deviations and the fit are comments at the top. The description is built from
the very text that is written (and read back), and :func:`write_calibrated_robot` writes
it atomically.
"""

from __future__ import annotations

import dataclasses
import json
import tomllib
from pathlib import Path

import numpy as np

from lab.description import RobotDescription, load_robot, parse_robot
from lab.errors import LabRuntimeError
from lab.fem.solve.parameters import as_built_description
from lab.files import atomic_write_text

__all__ = ["robot_toml", "calibrated_toml", "calibrated_robot", "write_calibrated_robot"]


def _f(v) -> str:
    return repr(float(v))


def _vec(v) -> str:
    return "[" + ", ".join(_f(c) for c in np.ravel(v)) + "]"


def robot_toml(robot: RobotDescription, header: list[str] = ()) -> str:
    """``robot`` as TOML text. Floats are written with ``repr``, so reading the text back
    gives the same description (sha256).

    Parameters
    ----------
    robot : RobotDescription
        The description to write (SI units, world frame W).
    header : list of str
        Comment lines for the top of the file, without the ``#``.

    Returns
    -------
    str
        The TOML text, in the format of ``lab/robots/*.toml``, ending in a newline.
    """
    lines = [f"# {h}".rstrip() for h in header]
    lines += [
        "format_version = 1",
        f"name = {json.dumps(robot.name)}",
        f"summary = {json.dumps(robot.summary)}",
        "",
        *_body_lines(robot),
        "",
        *_material_lines(robot),
    ]
    if np.any(robot.stiffness_gradient):
        lines.append(f"stiffness_gradient = {_vec(robot.stiffness_gradient)}")
    lines += ["", "[mounting]", f"gravity_m_s2 = {_vec(robot.gravity_m_s2)}", "", *_mesh_lines(robot)]
    actuation = ("spool_radius_m", "u_max_rad", "cable_stiffness_n_m", "slack_smoothing_m")
    if any(getattr(robot, k) is not None for k in actuation):  # none for a robot of tension tendons
        lines += ["", "[actuation]"]
        lines += [f"{k} = {_f(getattr(robot, k))}" for k in actuation if getattr(robot, k) is not None]
    for c in robot.cables:
        lines += ["", "[[cables]]", f"name = {json.dumps(c.name)}", f"anchor_m = {_vec(c.anchor_m)}"]
        lines += ["via_points_m = [", *(f"    {_vec(p)}," for p in c.via_points_m), "]"]
        if c.slack_m:
            lines.append(f"slack_m = {_f(c.slack_m)}")
        if c.control != "angle":
            lines += [f"control = {json.dumps(c.control)}", f"tension_max_n = {_f(c.tension_max_n)}"]
    for c in robot.chambers:
        lines += ["", "[[chambers]]", f"name = {json.dumps(c.name)}"]
        if c.control != "pressure":
            lines.append(f"control = {json.dumps(c.control)}")
        for key in CHAMBER_FIELDS:
            value = getattr(c, key)
            if value is not None:
                lines.append(f"{key} = {json.dumps(value) if isinstance(value, str) else _f(value)}")
    lines += ["", "[tip_marker]", f"position_m = {_vec(robot.p_tip_marker_W)}"]
    for m in robot.markers:
        lines += ["", "[[markers]]", f"name = {json.dumps(m.name)}", f"position_m = {_vec(m.position_m)}"]
    lines += ["", "[safety]"]
    for lim in robot.safety_limits:
        lines += [
            "[[safety.limits]]",
            f"cables = [{', '.join(str(int(i)) for i in lim.cables)}]",
            f"max_sum_over_u_max = {_f(lim.max_sum_over_u_max)}",
        ]
    return "\n".join(lines) + "\n"


#: The fields of a chamber written after its name and control (those set).
CHAMBER_FIELDS = (
    "pressure_max_pa",
    "pressure_min_pa",
    "volume_max_m3",
    "volume_min_m3",
    "fluid_bulk_modulus_pa",
    "angle_deg",
    "offset_m",
    "radius_m",
    "start_m",
    "end_m",
    "surface_group",
)


def _material_lines(robot: RobotDescription) -> list[str]:
    """The ``[material]`` table: the neo-Hookean modulus, or the Yeoh coefficients."""
    out = ["[material]"]
    if robot.material_model == "yeoh":
        out.append('model = "yeoh"')
        out += [f"yeoh_c{k}0_pa = {_f(c)}" for k, c in zip((1, 2, 3), robot.yeoh_c_pa)]
        if robot.bulk_modulus_pa is not None:
            out.append(f"bulk_modulus_pa = {_f(robot.bulk_modulus_pa)}")
        else:
            out.append(f"poisson_ratio = {_f(robot.poisson_ratio)}")
    else:
        out += [
            'model = "neo-hookean"',
            f"youngs_modulus_pa = {_f(robot.youngs_modulus_pa)}",
            f"poisson_ratio = {_f(robot.poisson_ratio)}",
        ]
    return out + [f"density_kg_m3 = {_f(robot.density_kg_m3)}"]


def _body_lines(robot: RobotDescription) -> list[str]:
    """The ``[body]`` table: a cylinder, a radius profile or a mesh file (its absolute path)."""
    shape = robot.body_shape
    if shape.shape == "tapered":
        rows = [f"    {_vec(p)}," for p in shape.profile_m]
        return ["[body]", 'shape = "tapered"', "profile_m = [", *rows, "]"]
    if shape.shape == "mesh":
        out = ["[body]", 'shape = "mesh"', f"mesh_file = {json.dumps(shape.mesh_file)}"]
        out.append(f"mesh_unit = {json.dumps(shape.mesh_unit)}")
        if shape.clamp_group is not None:
            return out + [f"clamp_group = {json.dumps(shape.clamp_group)}"]
        return out + [f"clamp = {json.dumps(shape.clamp)}"]
    return ["[body]", 'shape = "cylinder"', f"length_m = {_f(robot.length_m)}", f"radius_m = {_f(robot.radius_m)}"]


def _mesh_lines(robot: RobotDescription) -> list[str]:
    """The ``[mesh]`` table: the structured mesher's resolution, or a geometry's element size."""
    if robot.body_shape.shape == "mesh":
        shape = robot.body_shape
        size = [] if shape.mesh_size_m is None else [f"size_m = {_f(shape.mesh_size_m)}"]
        return ["[mesh]", *size, f"order = {int(shape.mesh_order)}"]
    if robot.chambers:  # a cylinder or tapered body meshed by gmsh around its cavities
        return ["[mesh]", f"size_m = {_f(robot.body_shape.mesh_size_m)}"]
    return ["[mesh]", f"n_rings = {int(robot.n_rings)}", f"n_axial = {int(robot.n_axial)}"]


def _header(robot: RobotDescription, result, source: str | None, command: str | None) -> list[str]:
    lay, v = result.layout, result.values
    fit = f"{len(result.residuals_m)} real samples" + (f" ({source})" if source else "")
    out = [
        f"Calibrated as-built description of {robot.name!r}, written by lab.transfer (python -m lab calibrate)",
        f"from {fit} on the {result.n_rings}-ring, {result.n_axial}-layer mesh (kept in [mesh]:",
        "the parameters absorb its discretisation error). Identified parameters, value +- 1 std",
        "(Gauss-Newton covariance with the prior), [nominal]:",
    ]
    for n, x, s, x0, unit in zip(lay.names, result.theta, result.std, result.theta_nominal, lay.units):
        out.append(f"  {n:<28} {x:+.6g} +- {s:.2g} {unit}   [{x0:+.6g}]")
    gradient = robot.stiffness_gradient[1:] if v["gradient"] is None else v["gradient"]
    line = (
        f"  softness = {v['softness']:.4g} (E = {v['softness'] * robot.youngs_modulus_pa:.6g} Pa), "
        f"gradient |g| = {np.hypot(*gradient):.3g}"
    )
    if "density" in lay.groups:
        line += f", density = {v['density'] * robot.density_kg_m3:.6g} kg/m^3"
    what = "Tip" if len(getattr(result, "markers", ("tip",))) == 1 else "Marker"
    out += [
        line,
        f"{what} misfit RMS {1e3 * result.rms_nominal_m:.3f} mm (nominal) -> {1e3 * result.rms_m:.3f} mm; "
        f"residual noise {1e3 * result.sigma_m:.3f} mm; {result.iterations} iterations"
        + ("" if result.converged else " (NOT converged)"),
    ]
    return out + ([f"Made by: {command}"] if command else []) + [""]


def calibrated_toml(robot: RobotDescription, result, source: str | None = None, command: str | None = None) -> str:
    """The TOML text of the calibrated robot.

    Parameters
    ----------
    robot : RobotDescription
        The nominal description the calibration started from.
    result : CalibrationResult
        The calibration (:func:`lab.transfer.calibrate`): identified theta, its mesh and fit.
    source : str, optional
        Where the real samples came from, recorded in a comment.
    command : str, optional
        The command line that made it, recorded in a comment.

    Returns
    -------
    str
        The TOML text: the as-built description on the calibration's mesh, with the
        identified parameters, their standard deviations and the fit as comments.

    Raises
    ------
    LabRuntimeError
        When the text does not read back as the same description (sha256).
    """
    built = as_built_description(robot, result.layout, result.theta)
    built = dataclasses.replace(
        built,
        n_rings=result.n_rings,
        n_axial=result.n_axial,
        summary=f"{robot.summary} (calibrated from {len(result.residuals_m)} real samples)",
    )
    text = robot_toml(built, _header(robot, result, source, command))
    if parse_robot(tomllib.loads(text)).sha256 != built.sha256:  # the writer must round-trip
        raise LabRuntimeError("internal error: the calibrated description does not read back the same")
    return text


def calibrated_robot(robot: RobotDescription, result, source: str | None = None) -> RobotDescription:
    """The calibrated robot as a description, read from the text :func:`calibrated_toml` writes.

    Parameters
    ----------
    robot : RobotDescription
        The nominal description the calibration started from.
    result : CalibrationResult
        The calibration (:func:`lab.transfer.calibrate`).
    source : str, optional
        Where the real samples came from, recorded in a comment.

    Returns
    -------
    RobotDescription
        The as-built description (identified modulus, gradient, eyelets and slack).
    """
    return parse_robot(tomllib.loads(calibrated_toml(robot, result, source)))


def write_calibrated_robot(
    path, robot: RobotDescription, result, source: str | None = None, command: str | None = None
) -> RobotDescription:
    """Write the calibrated robot to ``path`` (atomically) and return it as loaded from there.

    Parameters
    ----------
    path : str or Path
        The robot TOML file to write.
    robot : RobotDescription
        The nominal description the calibration started from.
    result : CalibrationResult
        The calibration (:func:`lab.transfer.calibrate`).
    source : str, optional
        Where the real samples came from, recorded in a comment.
    command : str, optional
        The command line that made it, recorded in a comment.

    Returns
    -------
    RobotDescription
        The description as loaded from ``path``.
    """
    atomic_write_text(path, calibrated_toml(robot, result, source, command))
    return load_robot(Path(path))
