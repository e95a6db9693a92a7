"""The draws of a family member: :func:`draw_member`, the defects document of ``twin:random:SEED``.

Member ``seed`` of the family of emulated as-built robots (:mod:`lab.asbuilt.family`) is drawn
here, uniformly and independently from :data:`RANGES` (:data:`FIXED`: hardware settings),
as the parsed TOML document that :func:`lab.asbuilt.arm.parse_defects` validates. The
global fields come from the random stream ``[seed, 0]``; cable ``i``'s slack and play from
``[seed, 1 + i, 0]``; its eyelet shift from ``[seed, 1 + j, 1]``, ``j`` the first cable
through the same first eyelet (such cables share one shift), so a cable's draws do not
depend on how many cables the robot has. A shift is shrunk along its direction where it
would put an eyelet too near the surface (:data:`SURFACE_COVER_M`), outside the mesh's
polygonal section (:data:`MESH_MARGIN_M`), near the base face or beyond the tip. The foam
family (:mod:`lab.asbuilt.foam`) starts from the same draw, so it lives in a module of
its own that both families import. Every range and why: ``docs/design/rig.md``.
"""

from __future__ import annotations

import math

import numpy as np

from lab.asbuilt.arm import FORMAT_VERSION
from lab.description import RobotDescription
from lab.errors import InputError

__all__ = ["RANGES", "FIXED", "SURFACE_COVER_M", "MESH_MARGIN_M", "check_seed", "rounded", "draw_member"]

#: (low, high) of each drawn field, SI units (m, s, Hz, rad/s); see the module docstring.
RANGES = {
    "softness": (0.55, 1.10),
    "gradient": (0.0, 0.60),
    "gradient_angle_deg": (0.0, 360.0),
    "radial_shift_m": (-3e-3, 3e-3),
    "tangential_shift_m": (-1.5e-3, 1.5e-3),
    "axial_shift_m": (-2e-3, 2e-3),
    "slack_m": (0.0, 5e-3),
    "play_m": (3e-5, 3e-4),
    "tau_fast_s": (0.2, 0.8),
    "tau_slow_s": (1.5, 4.0),
    "slow_fraction": (0.15, 0.45),
    "profile_velocity_rad_s": (1.5, 2.5),
    "noise_sigma_m": (5e-5, 3e-4),
    "dropout_rate_hz": (0.0, 0.2),
    "dropout_max_frames": (6, 48),
}
#: Fields every member shares (hardware settings, not tolerances).
FIXED = {"ticks_per_rev": 4096, "frame_rate_hz": 120.0}
#: Least foam over an eyelet (m), and least distance inside the mesh's polygonal section (m).
SURFACE_COVER_M = 1e-3
MESH_MARGIN_M = 2.5e-4
_BASE_MARGIN_M = 1e-3


def check_seed(seed) -> int:
    """``seed`` as an int, or InputError unless it is an integer >= 0."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"the robot seed must be a non-negative integer, got {seed!r}")
    return int(seed)


def _u(rng: np.random.Generator, key: str) -> float:
    lo, hi = RANGES[key]
    return float(rng.uniform(lo, hi))


def rounded(x: float, digits: int) -> float:
    """``x`` rounded to ``digits`` decimals, never -0.0 (what a file writes)."""
    return round(float(x), digits) + 0.0  # + 0.0: no "-0.0" in the file


def _largest_step(points_yz: np.ndarray, shift_yz: np.ndarray, limits: np.ndarray) -> float:
    """Largest t in [0, 1] with |p + t s| <= limit for every eyelet p (K, 2) m."""
    a = float(shift_yz @ shift_yz)
    if a == 0.0:
        return 1.0
    b = 2.0 * points_yz @ shift_yz
    c = np.einsum("ij,ij->i", points_yz, points_yz) - limits**2  # <= 0: the nominal eyelets fit
    roots = (-b + np.sqrt(np.maximum(b * b - 4 * a * c, 0.0))) / (2 * a)
    return float(min(1.0, max(0.0, roots.min())))


def _leader(robot: RobotDescription, i: int) -> int:
    """The first cable routed through the same first eyelet as cable ``i`` (``i`` if none):
    cables sharing eyelets (the six-cable arm's pairs) share their shift."""
    first = robot.cables[i].via_points_m[0]
    return next(j for j in range(i + 1) if np.allclose(robot.cables[j].via_points_m[0], first, rtol=0, atol=1e-9))


def _group_shift(robot: RobotDescription, leader: int, seed: int, r_limit: float) -> tuple[list, dict]:
    """The eyelet shift (3,) m of the cables led by ``leader`` and notes for the comments."""
    rng = np.random.default_rng([seed, 1 + leader, 1])
    radial, tangential, axial = (_u(rng, k) for k in ("radial_shift_m", "tangential_shift_m", "axial_shift_m"))
    spare_angle = float(rng.uniform(0.0, 2 * math.pi))  # radial direction of a cable on the axis
    members = [c for i, c in enumerate(robot.cables) if _leader(robot, i) == leader]
    V = np.concatenate([c.via_points_m for c in members])
    P, x = V[:, 1:], V[:, 0]
    centre = robot.cables[leader].via_points_m[:, 1:].mean(axis=0)
    norm = np.linalg.norm(centre)
    e_r = centre / norm if norm > 1e-9 else np.array([math.cos(spare_angle), math.sin(spare_angle)])
    e_t = np.array([-e_r[1], e_r[0]])
    s_yz = radial * e_r + tangential * e_t
    limits = np.maximum(r_limit, np.linalg.norm(P, axis=1))  # never tighter than the design itself
    t = _largest_step(P, s_yz, limits)
    s_yz = t * s_yz * (1 - 1e-6)
    dx = float(np.clip(axial, min(0.0, _BASE_MARGIN_M - x.min()), max(0.0, robot.length_m - x.max())))
    shift = [rounded(dx, 6), rounded(s_yz[0], 6), rounded(s_yz[1], 6)]
    notes = {
        "radial": float(s_yz @ e_r),
        "tangential": float(s_yz @ e_t),
        "axial": dx,
        "shrunk": t < 1.0,
        "axial_clipped": dx != axial,
        "leader": robot.cables[leader].name,
    }
    return shift, notes


def _cables(robot: RobotDescription, seed: int, r_limit: float) -> tuple[list, list]:
    """Tables of ``[[cables]]`` and notes for the comments."""
    leaders = [_leader(robot, i) for i in range(robot.n_cables)]
    shifts = {j: _group_shift(robot, j, seed, r_limit) for j in sorted(set(leaders))}
    tables, notes = [], []
    for i, cable in enumerate(robot.cables):
        rng = np.random.default_rng([seed, 1 + i, 0])
        slack, play = _u(rng, "slack_m"), _u(rng, "play_m")
        shift, note = shifts[leaders[i]]
        tables.append(
            {"name": cable.name, "via_shift_m": list(shift), "slack_m": rounded(slack, 5), "play_m": rounded(play, 6)}
        )
        notes.append({**note, "shared": leaders[i] != i})
    return tables, notes


def draw_member(robot: RobotDescription, seed: int, n_rings: int | None, n_axial: int | None) -> tuple[dict, dict]:
    """The drawn defects document of member ``seed`` of ``twin:random`` (what its TOML file
    holds; ``n_rings``/``n_axial``: the emulator mesh, written to ``[emulator]`` where
    given, whose section the eyelet shifts are kept inside) and the notes its comments
    need (:func:`lab.asbuilt.writer.defects_toml`)."""
    seed = check_seed(seed)
    rng = np.random.default_rng([seed, 0])
    softness, gradient, angle = (_u(rng, k) for k in ("softness", "gradient", "gradient_angle_deg"))
    tau_fast, tau_slow, slow_fraction = (_u(rng, k) for k in ("tau_fast_s", "tau_slow_s", "slow_fraction"))
    velocity, noise, rate = (_u(rng, k) for k in ("profile_velocity_rad_s", "noise_sigma_m", "dropout_rate_hz"))
    lo, hi = RANGES["dropout_max_frames"]
    max_frames = int(rng.integers(lo, hi + 1))
    rings = n_rings or robot.n_rings
    # The mesh's section is a polygon of 6 n_rings sides inscribed in the circle.
    r_limit = min(robot.radius_m - SURFACE_COVER_M, robot.radius_m * math.cos(math.pi / (6 * rings)) - MESH_MARGIN_M)
    cables, notes = _cables(robot, seed, r_limit)
    a = math.radians(angle)
    data = {
        "format_version": FORMAT_VERSION,
        "robot": robot.name,
        "material": {
            "softness": rounded(softness, 3),
            "gradient": rounded(gradient, 3),
            "gradient_direction": [0.0, rounded(math.cos(a), 4), rounded(math.sin(a), 4)],
        },
        "cables": cables,
        "lag": {
            "tau_fast_s": rounded(tau_fast, 2),
            "tau_slow_s": rounded(tau_slow, 2),
            "slow_fraction": rounded(slow_fraction, 2),
        },
        "motors": {"ticks_per_rev": FIXED["ticks_per_rev"], "profile_velocity_rad_s": rounded(velocity, 2)},
        "mocap": {
            "frame_rate_hz": FIXED["frame_rate_hz"],
            "noise_sigma_m": rounded(noise, 6),
            "dropout_rate_hz": rounded(rate, 3),
            "dropout_max_frames": max_frames,
        },
    }
    emulator = {k: v for k, v in (("n_rings", n_rings), ("n_axial", n_axial)) if v is not None}
    if emulator:
        data["emulator"] = emulator
    return data, {"angle": angle, "cables": notes}
