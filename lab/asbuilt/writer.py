"""Writing a drawn family member as a commented defects file (the format of ``lab/rig/defects/``).

A family (:mod:`lab.asbuilt.family`, ``twin:random:SEED``; :mod:`lab.asbuilt.foam`,
``twin:foam:SEED``) draws a member as the parsed TOML document ``data`` that
:func:`lab.asbuilt.arm.parse_defects` validates. :func:`defects_toml` writes that document
back as text, one field a line with a comment saying the range it was drawn from
(``U(lo, hi)`` uniform, ``logU(lo, hi)`` log-uniform) or how it was derived, table by table
in the order of the shipped file. The optional fields outside the calibrator's model class
(the hyperfoam law, cable stiffness, creep, the mocap's frame error, ``[mount]``) and a
pneumatic member's ``[[chambers]]`` (:mod:`lab.asbuilt.pneumatic`; it has no cables and no
motors) are written only where the member has them, so a ``twin:random`` member's file is exactly what
it always was. Every float is written so that it reads back to exactly the drawn value
(:func:`fmt_float`), and the text is checked to read back to ``data`` before it is returned:
the file *is* the member.
"""

from __future__ import annotations

import tomllib

import numpy as np

from lab.asbuilt.arm import FORMAT_VERSION
from lab.description import RobotDescription

__all__ = ["defects_toml", "chamber_lines", "fmt_float", "range_text"]


def fmt_float(x: float) -> str:
    """A float as TOML that reads back to exactly ``x`` (never an integer, no exponent)."""
    return np.format_float_positional(float(x), trim="0")


def _vec(v) -> str:
    return "[" + ", ".join(fmt_float(c) for c in v) + "]"


def _line(text: str, comment: str, width: int = 42) -> str:
    return f"{text:<{width}} # {comment}"


def range_text(ranges: dict, key: str, scale: float = 1.0, unit: str = "", log: bool = False) -> str:
    """``U(lo, hi)unit`` (``logU`` when ``log``) of ``ranges[key]`` scaled by ``scale``."""
    lo, hi = ranges[key]
    return f"{'logU' if log else 'U'}({lo * scale:g}, {hi * scale:g}){unit}"


def _material(mat: dict, angle: float, ranges: dict, nu: float) -> list[str]:
    out = [
        "[material]",
        _line(f"softness = {fmt_float(mat['softness'])}", f"E_as-built / E_nominal, {range_text(ranges, 'softness')}"),
        _line(
            f"gradient = {fmt_float(mat['gradient'])}",
            f"E = softness E_nom (1 + gradient s), {range_text(ranges, 'gradient')}",
        ),
        _line(
            f"gradient_direction = {_vec(mat['gradient_direction'])}",
            f"E increases toward {angle:.0f} deg round the section (0 = +y, 90 = +z)",
        ),
    ]
    if "law" in mat:
        out += [
            "# The compressible Ogden foam (Storakers; Abaqus HYPERFOAM, N = 1) instead of neo-Hookean;",
            "# mu and beta match the description's small-strain E and nu, scaled like E per tet.",
            _line(f'law = "{mat["law"]}"', "outside what `calibrate` fits"),
            _line(f"hyperfoam_mu_pa = {fmt_float(mat['hyperfoam_mu_pa'])}", "E_nom / (2 (1 + nu)), Pa"),
            _line(
                f"hyperfoam_alpha = {fmt_float(mat['hyperfoam_alpha'])}",
                f"large-strain stiffening, {range_text(ranges, 'hyperfoam_alpha')}",
            ),
            _line(f"hyperfoam_beta = {fmt_float(mat['hyperfoam_beta'])}", f"nu / (1 - 2 nu), nu = {nu:g}"),
        ]
    return out


def _cables(tables: list[dict], notes: list[dict], ranges: dict) -> list[str]:
    out = [
        "# One table per cable, in the description's order. via_shift_m moves every eyelet",
        "# (radial U(-3, 3) mm, + towards the surface; round the section U(-1.5, 1.5) mm;",
        "# along the body U(-2, 2) mm); slack_m U(0, 5) mm; play_m U(0.03, 0.3) mm.",
    ]
    if any("stiffness_n_per_m" in t for t in tables):
        k_range = range_text(ranges, "cable_stiffness_n_per_m", unit=" N/m", log=True)
        out.append(f"# stiffness_n_per_m {k_range}: the line stretches in series with the spool.")
    for table, note in zip(tables, notes):
        how = f"radial {1e3 * note['radial']:+.2f} mm, round {1e3 * note['tangential']:+.2f} mm"
        how += f", along {1e3 * note['axial']:+.2f} mm"
        if note["shared"]:
            how += f" (shares its eyelets with {note['leader']!r})"
        elif note["shrunk"]:
            how += " (shrunk to fit the body and mesh)"
        elif note["axial_clipped"]:
            how += " (kept within the body's length)"
        out += [
            "[[cables]]",
            f'name = "{table["name"]}"',
            _line(f"via_shift_m = {_vec(table['via_shift_m'])}", how),
            _line(f"slack_m = {fmt_float(table['slack_m'])}", f"tied off {1e3 * table['slack_m']:.2f} mm long"),
            _line(f"play_m = {fmt_float(table['play_m'])}", "friction play half-width, m of contraction"),
        ]
        if "stiffness_n_per_m" in table:
            k = table["stiffness_n_per_m"]
            out.append(_line(f"stiffness_n_per_m = {fmt_float(k)}", f"stretches {1e3 / k:.2f} mm per newton"))
        out.append("")
    return out


def chamber_lines(tables: list[dict], robot: RobotDescription, notes: dict, ranges: dict) -> list[str]:
    """The ``[[chambers]]`` tables of a pneumatic member, commented (see :mod:`lab.asbuilt.pneumatic`).

    Parameters
    ----------
    tables : list of dict
        One table per chamber, in the description's order.
    robot : RobotDescription
        The nominal robot (its chambers' full scale).
    notes : dict
        ``cavity_shrinks``: how many times the cavity draws were halved to keep the walls.
    ranges : dict
        (lo, hi) of each drawn field (:data:`lab.asbuilt.pneumatic.PNEUMATIC_RANGES`).

    Returns
    -------
    list of str
        The lines.
    """
    shrinks = notes.get("cavity_shrinks", 0)
    tangential = range_text(ranges, "tangential_error_m", 1e3, " mm")
    out = [
        "# One table per chamber, in the description's order: the cast cavity's core pin off its",
        f"# seat (offset_error_m {range_text(ranges, 'offset_error_m', 1e3, ' mm')} further from the axis; round the",
        f"# section {tangential}, written as angle_error_deg; radius_error_m",
        f"# {range_text(ranges, 'radius_error_m', 1e3, ' mm')}), the silicone round it `stiffness` times as stiff",
        f"# ({range_text(ranges, 'stiffness')}), and its pressure regulator: delivered = gain * command + offset",
        f"# (gain {range_text(ranges, 'regulator_gain')}, offset {range_text(ranges, 'regulator_offset_fs', 100, ' %')}"
        " of full scale), reached",
        f"# first-order (tau {range_text(ranges, 'regulator_tau_s', unit=' s')}) after a dead time "
        f"{range_text(ranges, 'regulator_dead_time_s', 1e3, ' ms')}.",
    ]
    if shrinks:
        out.append(f"# The cavity draws were halved {shrinks} time(s) to keep every wall one element thick.")
    for table, chamber in zip(tables, robot.chambers):
        fs = chamber.bounds[1]
        out += [
            "[[chambers]]",
            f'name = "{table["name"]}"',
            _line(
                f"offset_error_m = {fmt_float(table['offset_error_m'])}",
                f"axis at {chamber.offset_m * 1e3:g} mm + this",
            ),
            _line(
                f"angle_error_deg = {fmt_float(table['angle_error_deg'])}", f"axis at {chamber.angle_deg:g} deg + this"
            ),
            _line(
                f"radius_error_m = {fmt_float(table['radius_error_m'])}", f"radius {chamber.radius_m * 1e3:g} mm + this"
            ),
            _line(f"stiffness = {fmt_float(table['stiffness'])}", "modulus factor of the silicone round it"),
            _line(f"regulator_tau_s = {fmt_float(table['regulator_tau_s'])}", "first-order pressure response, s"),
            _line(f"regulator_dead_time_s = {fmt_float(table['regulator_dead_time_s'])}", "before it responds, s"),
            _line(f"regulator_gain = {fmt_float(table['regulator_gain'])}", "delivered per commanded pressure"),
            _line(
                f"regulator_offset_pa = {fmt_float(table['regulator_offset_pa'])}",
                f"{100 * table['regulator_offset_pa'] / fs:+.2f} % of {fs:g} Pa",
            ),
            "",
        ]
    return out


def _lag(lag: dict, ranges: dict) -> list[str]:
    out = [
        "[lag]",
        "# After a step the tip covers 1 - (1-w) exp(-t/tau_fast) - w exp(-t/tau_slow).",
        _line(f"tau_fast_s = {fmt_float(lag['tau_fast_s'])}", range_text(ranges, "tau_fast_s", unit=" s")),
        _line(f"tau_slow_s = {fmt_float(lag['tau_slow_s'])}", range_text(ranges, "tau_slow_s", unit=" s")),
        _line(f"slow_fraction = {fmt_float(lag['slow_fraction'])}", f"w, {range_text(ranges, 'slow_fraction')}"),
    ]
    if "creep_fraction" in lag:
        out += [
            "# With creep the fast share is 1 - w - c, and c exp(-t/creep_tau) is still to come.",
            _line(f"creep_fraction = {fmt_float(lag['creep_fraction'])}", f"c, {range_text(ranges, 'creep_fraction')}"),
            _line(f"creep_tau_s = {fmt_float(lag['creep_tau_s'])}", range_text(ranges, "creep_tau_s", unit=" s")),
        ]
    return out


def _mocap(moc: dict, ranges: dict) -> list[str]:
    out = [
        "[mocap]",
        _line(f"frame_rate_hz = {fmt_float(moc['frame_rate_hz'])}", "OptiTrack Prime 13 setting (fixed)"),
        _line(
            f"noise_sigma_m = {fmt_float(moc['noise_sigma_m'])}",
            f"per axis, {range_text(ranges, 'noise_sigma_m', 1e3, ' mm')}",
        ),
        _line(
            f"dropout_rate_hz = {fmt_float(moc['dropout_rate_hz'])}",
            f"bursts per second, {range_text(ranges, 'dropout_rate_hz')}",
        ),
        _line(f"dropout_max_frames = {moc['dropout_max_frames']}", "bursts last 1..this frames, U{6..48}"),
    ]
    if "frame_rotation_deg" in moc:
        out += [
            "# Frame W registered with an error: tips are reported at R_err p + frame_offset_m.",
            _line(
                f"frame_rotation_deg = {fmt_float(moc['frame_rotation_deg'])}",
                f"{range_text(ranges, 'frame_rotation_deg', unit=' deg')} about a random axis",
            ),
            f"frame_rotation_axis = {_vec(moc['frame_rotation_axis'])}",
        ]
    if "frame_offset_m" in moc:
        offset = range_text(ranges, "frame_offset_m", 1e3, " mm")
        out.append(_line(f"frame_offset_m = {_vec(moc['frame_offset_m'])}", f"per axis, {offset}"))
    return out


def _mount(mount: dict, azimuth_deg: float, ranges: dict) -> list[str]:
    tilt = range_text(ranges, "tilt_deg", unit=" deg")
    return [
        "[mount]",
        "# The base levelled by eye: the FEM solves with gravity R_tilt^T g in the body frame,",
        "# and the motion capture (registered with the level base) sees the tip at R_tilt p.",
        _line(f"tilt_deg = {fmt_float(mount['tilt_deg'])}", f"off level, {tilt}"),
        _line(
            f"tilt_axis = {_vec(mount['tilt_axis'])}",
            f"horizontal, {azimuth_deg:.0f} deg from +x toward +y",
        ),
        "",
    ]


def defects_toml(robot: RobotDescription, data: dict, notes: dict, *, header: list[str], ranges: dict) -> str:
    """The commented defects file of the drawn document ``data`` of ``robot``.

    ``notes``: what the comments say beyond the values -- ``angle`` (the gradient's
    direction, deg round the section), ``cables`` (one dict per cable: the eyelet shift's
    ``radial``/``tangential``/``axial`` parts in m, and whether it was ``shrunk``,
    ``axial_clipped`` or ``shared`` with its ``leader``) and, with ``[mount]``,
    ``tilt_azimuth_deg``. ``header``: the comment lines on top (the family, the seed, the
    command); ``ranges``: (lo, hi) of each drawn field, SI units. Raises AssertionError if
    the text does not read back to ``data``."""
    out = [
        *header,
        f"format_version = {FORMAT_VERSION}",
        f'robot = "{robot.name}"',
        "",
        *_material(data["material"], notes["angle"], ranges, robot.poisson_ratio),
        "",
    ]
    if "cables" in data:
        out += _cables(data["cables"], notes["cables"], ranges)
    if "chambers" in data:
        out += chamber_lines(data["chambers"], robot, notes, ranges)
    out += _lag(data["lag"], ranges)
    out.append("")
    if "motors" in data:
        mot = data["motors"]
        out += [
            "[motors]",
            _line(f"ticks_per_rev = {mot['ticks_per_rev']}", "Dynamixel XM430 encoder (fixed)"),
            _line(
                f"profile_velocity_rad_s = {fmt_float(mot['profile_velocity_rad_s'])}",
                range_text(ranges, "profile_velocity_rad_s", unit=" rad/s"),
            ),
            "",
        ]
    out += [*_mocap(data["mocap"], ranges), ""]
    if "mount" in data:
        out += _mount(data["mount"], notes["tilt_azimuth_deg"], ranges)
    if "emulator" in data:
        out += ["[emulator]", *(f"{k} = {v}" for k, v in data["emulator"].items()), ""]
    elif "chambers" in data:
        out += ["# No [emulator]: a body with chambers is meshed by gmsh at the description's [mesh] size_m.", ""]
    else:
        out += ["# [emulator]          # optional: FEM mesh of the twin (default: the description's)", ""]
    text = "\n".join(out)
    if tomllib.loads(text) != data:  # the file must read back to exactly the drawn values
        raise AssertionError("lab.asbuilt.writer: the written defects file does not read back to the draw")
    return text
