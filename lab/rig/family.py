"""A family of emulated as-built robots: seeded, random defects files (``--rig twin:random:SEED``).

The shipped defects file is *one* as-built arm; a finding that holds on it may hold only on
it. :func:`random_defects` draws member ``seed`` of a family of as-built arms instead, for
any robot description, uniformly and independently from :data:`RANGES` (every range
contains the shipped value and is wider than its spread; :data:`FIXED` holds hardware
settings). A cable's draws do not depend on how many cables the robot has, and the same
seed gives the same robot and the same file. Results on such a robot are an **emulated
as-built robot** (:data:`LABEL`), never the real arm. :func:`random_defects_toml` writes a
member as a commented defects file (``python -m lab defects --random SEED``),
:func:`write_random_defects` atomically; :class:`FamilyTwinRig` is the twin rig on one.
Every range and why it is that wide: ``docs/design/rig.md``.
"""

from __future__ import annotations

import math
import tomllib

import numpy as np

from lab.description import RobotDescription
from lab.errors import InputError
from lab.files import atomic_write_text
from lab.rig.asbuilt import FORMAT_VERSION, Defects, as_built_robot, load_defects, parse_defects
from lab.rig.spec import parse_robot_seed
from lab.rig.twin import AsBuiltBody, TwinRig

__all__ = [
    "FAMILY_VERSION",
    "RANGES",
    "FIXED",
    "LABEL",
    "random_defects",
    "family_member",
    "random_defects_toml",
    "write_random_defects",
    "parse_robot_seed",
    "FamilyTwinRig",
]

#: Version of the generator: a change of ranges or draws bumps it (same seed, other robot).
FAMILY_VERSION = 1
#: What results on a member of the family are.
LABEL = "emulated as-built robot"
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


def _check_seed(seed) -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"the robot seed must be a non-negative integer, got {seed!r}")
    return int(seed)


def _u(rng: np.random.Generator, key: str) -> float:
    lo, hi = RANGES[key]
    return float(rng.uniform(lo, hi))


def _r(x: float, digits: int) -> float:
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
    shift = [_r(dx, 6), _r(s_yz[0], 6), _r(s_yz[1], 6)]
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
        tables.append({"name": cable.name, "via_shift_m": list(shift), "slack_m": _r(slack, 5), "play_m": _r(play, 6)})
        notes.append({**note, "shared": leaders[i] != i})
    return tables, notes


def _draw(robot: RobotDescription, seed: int, n_rings: int | None, n_axial: int | None) -> tuple[dict, list]:
    seed = _check_seed(seed)
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
            "softness": _r(softness, 3),
            "gradient": _r(gradient, 3),
            "gradient_direction": [0.0, _r(math.cos(a), 4), _r(math.sin(a), 4)],
        },
        "cables": cables,
        "lag": {"tau_fast_s": _r(tau_fast, 2), "tau_slow_s": _r(tau_slow, 2), "slow_fraction": _r(slow_fraction, 2)},
        "motors": {"ticks_per_rev": FIXED["ticks_per_rev"], "profile_velocity_rad_s": _r(velocity, 2)},
        "mocap": {
            "frame_rate_hz": FIXED["frame_rate_hz"],
            "noise_sigma_m": _r(noise, 6),
            "dropout_rate_hz": _r(rate, 3),
            "dropout_max_frames": max_frames,
        },
    }
    emulator = {k: v for k, v in (("n_rings", n_rings), ("n_axial", n_axial)) if v is not None}
    if emulator:
        data["emulator"] = emulator
    return data, [angle, *notes]


def random_defects(
    robot: RobotDescription, seed: int, *, n_rings: int | None = None, n_axial: int | None = None
) -> Defects:
    """Member ``seed`` (an integer >= 0) of the family of as-built ``robot``s (ranges in the
    module docstring). ``n_rings``/``n_axial``: the emulator's FEM mesh, written to the
    file's ``[emulator]`` (default: the description's); eyelet shifts are kept inside it."""
    data, _ = _draw(robot, seed, n_rings, n_axial)
    defects = parse_defects(data, robot, f"random:{int(seed)}")
    as_built_robot(robot, defects)  # eyelets inside the body (guaranteed by the draw)
    return defects


def family_member(robot: RobotDescription, label: str, **mesh) -> Defects:
    """The defects of a robot as the studies name it: ``"shipped"`` (its shipped defects file)
    or ``"random:SEED"`` (:func:`random_defects`, for the mesh ``n_rings``/``n_axial``)."""
    if label == "shipped":
        return load_defects(None, robot)
    return random_defects(robot, parse_robot_seed(label.removeprefix("random:"), label), **mesh)


def _f(x: float) -> str:
    """A float as TOML that reads back to exactly ``x`` (never an integer, no exponent)."""
    return np.format_float_positional(float(x), trim="0")


def _vec(v) -> str:
    return "[" + ", ".join(_f(c) for c in v) + "]"


def _line(text: str, comment: str, width: int = 42) -> str:
    return f"{text:<{width}} # {comment}"


def _range(key: str, scale: float = 1.0, unit: str = "") -> str:
    lo, hi = RANGES[key]
    return f"U({lo * scale:g}, {hi * scale:g}){unit}"


def random_defects_toml(
    robot: RobotDescription,
    seed: int,
    *,
    n_rings: int | None = None,
    n_axial: int | None = None,
    command: str | None = None,
) -> str:
    """The defects file (TOML text with comments) of member ``seed``: what
    :func:`random_defects` returns, in the format of the shipped file. ``command``: the
    command line that made it, recorded in the header (default: the equivalent one)."""
    data, (angle, *notes) = _draw(robot, seed, n_rings, n_axial)
    mesh = "".join(f" --{k.replace('_', '-')} {v}" for k, v in data.get("emulator", {}).items())
    command = command or f"python -m lab defects --random {int(seed)} --robot {robot.name}{mesh} --out D.toml"
    mat, lag, mot, moc = (data[k] for k in ("material", "lag", "motors", "mocap"))
    out = [
        f"# As-built defects of {robot.name!r}: member {int(seed)} of the family of {LABEL}s",
        f"# (lab/rig/family.py, generator version {FAMILY_VERSION}; --rig twin:random:{int(seed)}), made by",
        f"#     {command}",
        "# Every value is drawn uniformly from the range in its comment; lab/rig/family.py",
        "# says why each range is what it is (foam and fabrication tolerances). Results on",
        f"# this robot are an {LABEL}, not the real arm. Frame W as in the",
        "# description (base at the origin, body along +x, gravity along -z); SI units.",
        "# Every field is validated by lab/rig/asbuilt.py, which also documents the model.",
        f"format_version = {FORMAT_VERSION}",
        f'robot = "{robot.name}"',
        "",
        "[material]",
        _line(f"softness = {_f(mat['softness'])}", f"E_as-built / E_nominal, {_range('softness')}"),
        _line(f"gradient = {_f(mat['gradient'])}", f"E = softness E_nom (1 + gradient s), {_range('gradient')}"),
        _line(
            f"gradient_direction = {_vec(mat['gradient_direction'])}",
            f"E increases toward {angle:.0f} deg round the section (0 = +y, 90 = +z)",
        ),
        "",
        "# One table per cable, in the description's order. via_shift_m moves every eyelet",
        "# (radial U(-3, 3) mm, + towards the surface; round the section U(-1.5, 1.5) mm;",
        "# along the body U(-2, 2) mm); slack_m U(0, 5) mm; play_m U(0.03, 0.3) mm.",
    ]
    for table, note in zip(data["cables"], notes):
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
            _line(f"slack_m = {_f(table['slack_m'])}", f"tied off {1e3 * table['slack_m']:.2f} mm long"),
            _line(f"play_m = {_f(table['play_m'])}", "friction play half-width, m of contraction"),
            "",
        ]
    out += [
        "[lag]",
        "# After a step the tip covers 1 - (1-w) exp(-t/tau_fast) - w exp(-t/tau_slow).",
        _line(f"tau_fast_s = {_f(lag['tau_fast_s'])}", _range("tau_fast_s", unit=" s")),
        _line(f"tau_slow_s = {_f(lag['tau_slow_s'])}", _range("tau_slow_s", unit=" s")),
        _line(f"slow_fraction = {_f(lag['slow_fraction'])}", f"w, {_range('slow_fraction')}"),
        "",
        "[motors]",
        _line(f"ticks_per_rev = {mot['ticks_per_rev']}", "Dynamixel XM430 encoder (fixed)"),
        _line(
            f"profile_velocity_rad_s = {_f(mot['profile_velocity_rad_s'])}",
            _range("profile_velocity_rad_s", unit=" rad/s"),
        ),
        "",
        "[mocap]",
        _line(f"frame_rate_hz = {_f(moc['frame_rate_hz'])}", "OptiTrack Prime 13 setting (fixed)"),
        _line(f"noise_sigma_m = {_f(moc['noise_sigma_m'])}", f"per axis, {_range('noise_sigma_m', 1e3, ' mm')}"),
        _line(f"dropout_rate_hz = {_f(moc['dropout_rate_hz'])}", f"bursts per second, {_range('dropout_rate_hz')}"),
        _line(f"dropout_max_frames = {moc['dropout_max_frames']}", "bursts last 1..this frames, U{6..48}"),
        "",
    ]
    if "emulator" in data:
        out += ["[emulator]", *(f"{k} = {v}" for k, v in data["emulator"].items()), ""]
    else:
        out += ["# [emulator]          # optional: FEM mesh of the twin (default: the description's)", ""]
    text = "\n".join(out)
    if tomllib.loads(text) != data:  # the file must read back to exactly the drawn values
        raise AssertionError("lab.rig.family: the written defects file does not read back to the draw")
    return text


def write_random_defects(
    path, robot: RobotDescription, seed: int, *, n_rings=None, n_axial=None, command=None
) -> Defects:
    """Write member ``seed``'s defects file to ``path`` atomically; returns its
    :class:`Defects` (what :func:`lab.rig.asbuilt.load_defects` reads back from ``path``)."""
    text = random_defects_toml(robot, seed, n_rings=n_rings, n_axial=n_axial, command=command)
    defects = random_defects(robot, seed, n_rings=n_rings, n_axial=n_axial)
    atomic_write_text(path, text)
    return defects


class FamilyTwinRig(TwinRig):
    """The twin rig on member ``robot_seed`` of the family (``--rig twin:random:SEED``).

    ``seed`` is the motion-capture noise seed, as for :class:`TwinRig`. ``describe()``
    records the robot seed, the generator version and the label, so that a dataset says
    which robot it came from."""

    def __init__(self, robot: RobotDescription, robot_seed: int, seed: int = 0, **mesh):
        self.robot_seed = _check_seed(robot_seed)
        defects = random_defects(robot, self.robot_seed, **mesh)
        super().__init__(robot, seed=seed, body=AsBuiltBody(robot, defects))

    def describe(self) -> dict:
        return {
            **super().describe(),
            "label": LABEL,
            "family": {"robot_seed": self.robot_seed, "generator": "lab.rig.family", "version": FAMILY_VERSION},
        }
