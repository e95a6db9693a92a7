"""The pneumatic family's draw: cast-silicone arms with pressure chambers (``twin:pneumatic:SEED``).

Member ``seed`` of the pneumatic family (:data:`lab.asbuilt.PNEUMATIC`) is an as-built copy
of a robot driven by pressure chambers alone (``lab/robots/pneumatic-arm.toml`` first): a
silicone body cast round core pins in a printed mould, each chamber fed by a proportional
pressure regulator through a metre of 4 mm tube. :func:`draw_pneumatic` draws, uniformly
from :data:`PNEUMATIC_RANGES` (ranges reasoned from casting and datasheet tolerances; none
is fitted to a measured arm):

* ``softness`` U(0.85, 1.15) on the description's Yeoh law: batch to batch, a platinum-cure
  silicone's modulus moves with the mixing ratio (weighed by hand to ~1 %), the cure's
  temperature and degassing; the C10 that Polygerinos et al. (IEEE T-RO 31(3), 2015) fit to
  Elastosil M4601 and the datasheet's Shore 28A allow ~15 % either way;
* a curing ``gradient`` U(0, 0.15) in a random direction across the section: filler settling
  and a warmer top surface in an upright mould (the foam family's 0.6 is a foam's density
  gradient; a silicone is far more uniform);
* per chamber, the core pin off its seat: the cavity's axis U(-0.4, 0.4) mm further out and
  U(-0.4, 0.4) mm round the section (an FDM mould's ~0.1-0.2 mm positional error, the pin's
  clearance in its seat, and its bending over 18 cm under the poured silicone), its radius
  U(-0.15, 0.15) mm off (a printed or turned pin's diameter). The moved cavities must pass
  the description's wall check (:func:`lab.description.chambers.check_chamber_geometry`);
  a draw that does not is shrunk by half until it does (never at the nominal arm's walls);
* per chamber, the silicone round it (:data:`lab.asbuilt.chambered.WALL_REACH`) U(0.85, 1.15)
  stiffer: air trapped under a core pin, a pocket mixed less well;
* the base tilted U(0, 2) deg about a random horizontal axis (levelled by eye, as the foam
  family's);
* per chamber, its regulator: a first-order pressure response of tau U(0.03, 0.3) s after a
  dead time U(5, 30) ms (a proportional regulator such as SMC's ITV1000 answers in ~0.1 s
  unloaded; a metre of 4 mm tube and the ~12 mL cavity add volume to fill; the regulator's
  control loop and sound's 3 ms along the tube are the dead time), a gain U(0.985, 1.015)
  and an offset U(-1.5, 1.5) % of the chamber's ``pressure_max_pa`` (linearity +-1 % of full
  scale, hysteresis and repeatability +-0.5 %: the ITV series' datasheet figures);
* the silicone's own relaxation (``[lag]``): a fast mode tau U(0.02, 0.08) s (the body's
  damped settling) and a slow viscoelastic one U(1, 5) s taking U(0.02, 0.08) of each step
  (a platinum-cure silicone relaxes a few per cent, far less than a foam's 15-45 %);
* motion-capture noise and dropouts as the cable families' (:data:`lab.asbuilt.draw.RANGES`).

The global draws come from the stream ``[seed, 0, 3]``, chamber ``i``'s from
``[seed, 1 + i, 3]``, so a chamber's draws do not depend on how many chambers there are.
Results on a member are an **emulated as-built robot (pneumatic family)**; the rig takes
the chambers' pressures (Pa) as its commands (:class:`lab.rig.pneumatic_body.PneumaticBody`).
"""

from __future__ import annotations

import math

import numpy as np

from lab.asbuilt.arm import FORMAT_VERSION
from lab.asbuilt.draw import FIXED, RANGES, check_seed, rounded
from lab.description import RobotDescription
from lab.errors import FieldError, InputError

__all__ = ["PNEUMATIC_RANGES", "check_pneumatic_robot", "draw_pneumatic"]

#: (low, high) of each drawn field, SI units (m, deg, s; the regulator offset as a share of
#: the chamber's full scale); every one uniform. See the module docstring for why.
PNEUMATIC_RANGES = {
    "softness": (0.85, 1.15),
    "gradient": (0.0, 0.15),
    "gradient_angle_deg": (0.0, 360.0),
    "offset_error_m": (-4e-4, 4e-4),
    "tangential_error_m": (-4e-4, 4e-4),
    "radius_error_m": (-1.5e-4, 1.5e-4),
    "stiffness": (0.85, 1.15),
    "tilt_deg": (0.0, 2.0),
    "regulator_tau_s": (0.03, 0.3),
    "regulator_dead_time_s": (0.005, 0.03),
    "regulator_gain": (0.985, 1.015),
    "regulator_offset_fs": (-0.015, 0.015),
    "tau_fast_s": (0.02, 0.08),
    "tau_slow_s": (1.0, 5.0),
    "slow_fraction": (0.02, 0.08),
    **{k: RANGES[k] for k in ("noise_sigma_m", "dropout_rate_hz", "dropout_max_frames")},
}
#: Halvings of a cavity draw that fails the wall check before it is dropped (zeroed).
_SHRINKS = 6


def check_pneumatic_robot(robot: RobotDescription) -> None:
    """Refuse a robot the pneumatic family cannot draw (InputError naming why).

    Parameters
    ----------
    robot : RobotDescription
        The nominal robot: it must have pressure-controlled chambers with cast cavities
        (a cylinder or tapered body) and no cables.
    """
    chambers = tuple(getattr(robot, "chambers", ()))
    if not chambers:
        raise InputError(
            f"robot {robot.name!r} has no pressure chambers: the pneumatic family (twin:pneumatic:SEED) draws "
            "cast-silicone arms driven by chambers (the shipped pneumatic-arm, or your own robot with "
            "[[chambers]]); draw a cable arm from twin:random:SEED or twin:foam:SEED"
        )
    if robot.n_cables:
        raise InputError(f"robot {robot.name!r} has cables too: the pneumatic family draws chamber-driven arms alone")
    bad = [c.name for c in chambers if c.control != "pressure" or c.radius_m is None]
    if bad:
        raise InputError(
            f"robot {robot.name!r}: chamber {bad[0]!r} is not a pressure-controlled cast cavity (angle_deg, offset_m, "
            "radius_m); the pneumatic family draws core-pin errors and pressure regulators"
        )


def _u(rng: np.random.Generator, key: str) -> float:
    lo, hi = PNEUMATIC_RANGES[key]
    return float(rng.uniform(lo, hi))


def _fits(robot: RobotDescription, errors: list[tuple[float, float, float]]) -> bool:
    """Whether the chambers moved by (offset, angle, radius) errors pass the wall check."""
    import dataclasses

    from lab.description.chambers import check_chamber_geometry

    moved = [
        dataclasses.replace(c, offset_m=c.offset_m + o, angle_deg=c.angle_deg + a, radius_m=c.radius_m + r)
        for c, (o, a, r) in zip(robot.chambers, errors)
    ]
    try:
        check_chamber_geometry(moved, robot.length_m, robot.radius_at, robot.body_shape.mesh_size_m)
    except InputError:
        return False
    return True


def _cavity_errors(robot: RobotDescription, draws: list[tuple[float, float, float]]) -> tuple[list, int]:
    """The drawn (offset m, angle deg, radius m) errors, halved until the walls hold; and the
    number of halvings (``_SHRINKS + 1``: dropped)."""
    for k in range(_SHRINKS + 1):
        s = 0.5**k
        errors = []
        for c, (o, t, r) in zip(robot.chambers, draws):
            angle = math.degrees(math.atan2(s * t, c.offset_m)) if c.offset_m > 0 else 0.0
            errors.append((rounded(s * o, 6), rounded(angle, 3), rounded(s * r, 6)))
        if _fits(robot, errors):
            return errors, k
    return [(0.0, 0.0, 0.0)] * len(draws), _SHRINKS + 1


def draw_pneumatic(robot: RobotDescription, seed: int, n_rings: int | None, n_axial: int | None) -> tuple[dict, dict]:
    """The drawn defects document of pneumatic member ``seed`` and the notes its comments need.

    Parameters
    ----------
    robot : RobotDescription
        The nominal robot (:func:`check_pneumatic_robot`).
    seed : int
        The member, an integer >= 0.
    n_rings, n_axial : None
        Refused (InputError): a body with chambers is meshed by gmsh at ``[mesh] size_m``.

    Returns
    -------
    tuple of dict
        The parsed TOML document (:func:`lab.asbuilt.parse.parse_defects` validates it) and
        the notes :func:`lab.asbuilt.writer.defects_toml` writes as comments.
    """
    seed = check_seed(seed)
    check_pneumatic_robot(robot)
    if n_rings is not None or n_axial is not None:
        raise FieldError(
            f"robot {robot.name!r}: a body with chambers is meshed by gmsh at [mesh] size_m; MeshSpec.n_rings and "
            "MeshSpec.n_axial are for the structured meshes of the cable arms",
            "MeshSpec.n_rings",
            "MeshSpec.n_axial",
        )
    rng = np.random.default_rng([seed, 0, 3])
    softness, gradient, angle = (_u(rng, k) for k in ("softness", "gradient", "gradient_angle_deg"))
    tilt, azimuth = _u(rng, "tilt_deg"), float(rng.uniform(0.0, 360.0))
    tau_fast, tau_slow, slow = (_u(rng, k) for k in ("tau_fast_s", "tau_slow_s", "slow_fraction"))
    noise, rate = _u(rng, "noise_sigma_m"), _u(rng, "dropout_rate_hz")
    lo, hi = PNEUMATIC_RANGES["dropout_max_frames"]
    max_frames = int(rng.integers(lo, hi + 1))
    draws, regulators = [], []
    for i, chamber in enumerate(robot.chambers):
        r = np.random.default_rng([seed, 1 + i, 3])
        draws.append(tuple(_u(r, k) for k in ("offset_error_m", "tangential_error_m", "radius_error_m")))
        regulators.append({k: _u(r, k) for k in ("stiffness", "regulator_tau_s", "regulator_dead_time_s")})
        regulators[-1]["gain"] = _u(r, "regulator_gain")
        regulators[-1]["offset"] = _u(r, "regulator_offset_fs") * chamber.bounds[1]
    errors, shrinks = _cavity_errors(robot, draws)
    chambers = [
        {
            "name": c.name,
            "offset_error_m": o,
            "angle_error_deg": a,
            "radius_error_m": rr,
            "stiffness": rounded(g["stiffness"], 3),
            "regulator_tau_s": rounded(g["regulator_tau_s"], 3),
            "regulator_dead_time_s": rounded(g["regulator_dead_time_s"], 4),
            "regulator_gain": rounded(g["gain"], 4),
            "regulator_offset_pa": rounded(g["offset"], 0),
        }
        for c, (o, a, rr), g in zip(robot.chambers, errors, regulators)
    ]
    a, b = math.radians(angle), math.radians(azimuth)
    data = {
        "format_version": FORMAT_VERSION,
        "robot": robot.name,
        "material": {
            "softness": rounded(softness, 3),
            "gradient": rounded(gradient, 3),
            "gradient_direction": [0.0, rounded(math.cos(a), 4), rounded(math.sin(a), 4)],
        },
        "chambers": chambers,
        "lag": {
            "tau_fast_s": rounded(tau_fast, 3),
            "tau_slow_s": rounded(tau_slow, 2),
            "slow_fraction": rounded(slow, 3),
        },
        "mocap": {
            "frame_rate_hz": FIXED["frame_rate_hz"],
            "noise_sigma_m": rounded(noise, 6),
            "dropout_rate_hz": rounded(rate, 3),
            "dropout_max_frames": max_frames,
        },
        "mount": {"tilt_deg": rounded(tilt, 3), "tilt_axis": [rounded(math.cos(b), 4), rounded(math.sin(b), 4), 0.0]},
    }
    return data, {"angle": angle, "tilt_azimuth_deg": azimuth, "cavity_shrinks": shrinks}
