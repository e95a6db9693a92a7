"""The fields of a defects file: :class:`Defects`, their allowed ranges and validators.

A defects file (read by :func:`lab.asbuilt.parse.parse_defects`) says how an as-built
arm differs from its description. The fields ``calibrate`` can fit (softness, gradient,
eyelet shifts, slack) live beside optional ones outside that model class, each absent by
default so that an older file means exactly what it meant before:

* ``[mount] tilt_deg``, ``tilt_axis``: the base mounted off level. The FEM solves in the
  body frame with gravity ``R_tilt^T g``; the motion capture, registered with the room and
  the nominal (level) base pose, sees the body rotated about the base origin: the tip is
  reported at ``R_tilt p_body``. ``R_tilt`` turns by ``tilt_deg`` about ``tilt_axis``
  (right-handed, frame W). Within +-30 deg: a larger angle is a different mounting
  (write it in the description's ``[mounting] gravity_m_s2``), not a levelling error.
* ``[mocap] frame_rotation_deg``, ``frame_rotation_axis``, ``frame_offset_m``: the error of
  registering frame W (ground plane and origin): every tip is reported at
  ``R_err p + frame_offset_m``, in the misregistered frame. Rotation within +-10 deg (a
  calibration square placed by eye is better than a few degrees), offset within 0.1 m
  (half the arm's length: a larger one is a wrong origin, not a registration error).
* ``[[cables]] stiffness_n_per_m``: the cable's own stiffness (N/m), in series with the
  spool: it lengthens by tension / stiffness. 10 N/m (a rubber band: 10 cm per newton)
  to 1e12 N/m (beyond which it is inextensible to rounding). Absent: inextensible.
* ``[lag] creep_fraction``, ``creep_tau_s``: a third, slow mode of the foam's relaxation
  (minutes: creep), taking ``creep_fraction`` of each step; fraction in [0, 1) with
  ``slow_fraction + creep_fraction < 1`` (the fast mode keeps a share); time constant from
  ``tau_slow_s`` to 86400 s (a day: slower is a permanent set, not creep). Absent: 0.
* ``[material] law = "neo-hookean" | "hyperfoam"`` with ``hyperfoam_mu_pa`` (> 0, the
  initial shear modulus, scaled per tet by softness and gradient), ``hyperfoam_alpha``
  (nonzero, |alpha| <= 50: foams fit 2..25) and ``hyperfoam_beta`` (0 <= beta < 50; beta
  = nu / (1 - 2 nu), so nu from 0 to 0.49): the compressible Ogden foam (N = 1).
* ``[[chambers]]`` (a robot with pressure chambers, one table per chamber in the
  description's order; :class:`ChamberDefects`): the cast cavity's errors (``offset_error_m``
  off the axis, within +-5 mm; ``angle_error_deg`` round the section, within +-30 deg;
  ``radius_error_m`` within +-2 mm -- more is another design, not a casting tolerance;
  the moved cavity must still pass the description's wall check), the modulus factor
  ``stiffness`` of the silicone around it (0.2 to 5), and its pressure regulator: a first
  order response ``regulator_tau_s`` (1 ms to 10 s) after ``regulator_dead_time_s`` (0 to
  1 s), delivering ``regulator_gain`` (0.5 to 1.5) times the command plus
  ``regulator_offset_pa`` (within 10 % of the chamber's ``pressure_max_pa``: a larger
  offset is a broken regulator). A robot without cables needs no ``[[cables]]`` and no
  ``[motors]``.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field

import numpy as np

from lab.errors import InputError

#: Material laws a defects file may name.
LAWS = ("neo-hookean", "hyperfoam")
#: Allowed ranges of the optional fields (inclusive; see the module docstring for why).
TILT_RANGE_DEG = (-30.0, 30.0)
FRAME_ROTATION_RANGE_DEG = (-10.0, 10.0)
FRAME_OFFSET_LIMIT_M = 0.1
CABLE_STIFFNESS_RANGE_N_PER_M = (10.0, 1e12)
CREEP_TAU_LIMIT_S = 86400.0
HYPERFOAM_ALPHA_LIMIT = 50.0
HYPERFOAM_BETA_LIMIT = 50.0
#: Limits of a ``[[chambers]]`` table's fields (see the module docstring for why).
CHAMBER_OFFSET_ERROR_LIMIT_M = 5e-3
CHAMBER_ANGLE_ERROR_LIMIT_DEG = 30.0
CHAMBER_RADIUS_ERROR_LIMIT_M = 2e-3
CHAMBER_STIFFNESS_RANGE = (0.2, 5.0)
REGULATOR_TAU_RANGE_S = (1e-3, 10.0)
REGULATOR_DEAD_TIME_RANGE_S = (0.0, 1.0)
REGULATOR_GAIN_RANGE = (0.5, 1.5)
#: The largest regulator offset, as a share of the chamber's ``pressure_max_pa``.
REGULATOR_OFFSET_LIMIT_FS = 0.1


class DefectsError(InputError):
    """A defects file is missing a field, has an invalid value, or does not fit the robot."""


@dataclass(frozen=True)
class CableDefects:
    """As-built cable ``name``: eyelet shift ``via_shift_m`` (3,) m in frame W, extra free
    length ``slack_m`` (m), play half-width ``play_m`` (m of contraction), and its own
    stiffness ``stiffness_n_per_m`` (N/m, in series with the spool; None: inextensible)."""

    name: str
    via_shift_m: np.ndarray
    slack_m: float
    play_m: float
    stiffness_n_per_m: float | None = None


@dataclass(frozen=True)
class ChamberDefects:
    """As-built chamber ``name`` and its pressure regulator.

    Parameters
    ----------
    name : str
        The description's chamber.
    offset_error_m : float
        The cast cavity's axis further from the body's axis than designed, m.
    angle_error_deg : float
        The cavity turned round the section (about +x), deg.
    radius_error_m : float
        The cavity's radius larger than designed, m.
    stiffness : float
        Factor on the modulus of the silicone around the cavity (its wall).
    regulator_tau_s : float
        Time constant of the pressure's first-order response, s.
    regulator_dead_time_s : float
        Delay before the pressure starts to respond, s.
    regulator_gain : float
        Delivered pressure per commanded pressure (before the offset).
    regulator_offset_pa : float
        Delivered pressure at a zero command (gauge, Pa; never below the chamber's minimum).
    """

    name: str
    offset_error_m: float
    angle_error_deg: float
    radius_error_m: float
    stiffness: float
    regulator_tau_s: float
    regulator_dead_time_s: float
    regulator_gain: float
    regulator_offset_pa: float


@dataclass(frozen=True)
class Defects:
    """A validated defects file (see :mod:`lab.asbuilt.arm` and this module's docstring).

    Attributes
    ----------
    robot : str
        Name of the robot the file is for.
    softness : float
        Factor (> 0) on the description's Young's modulus.
    gradient : float
        Casting gradient in [0, 1]: the modulus is scaled by ``1 + gradient * s``, s in
        [-1, 1] the position along ``gradient_direction_W`` over the body radius.
    gradient_direction_W : numpy.ndarray
        Unit direction, shape (3,), across the section in frame W (x component 0).
    cables : tuple of CableDefects
        One per cable of the robot, in its order (eyelet shift, slack, play, stiffness).
    tau_fast_s, tau_slow_s : float
        Time constants (s) of the foam's fast and slow relaxation modes.
    slow_fraction : float
        Share of each step taken by the slow mode.
    ticks_per_rev : int
        Encoder ticks per motor revolution (0: no rounding).
    profile_velocity_rad_s : float
        Motor speed (rad/s) toward a goal.
    frame_rate_hz : float
        Motion-capture frame rate (Hz).
    noise_sigma_m : float
        Motion-capture noise per axis (m).
    dropout_rate_hz : float
        Rate (1/s) at which occlusion bursts start.
    dropout_max_frames : int
        Longest occlusion burst (frames).
    n_rings, n_axial : int or None
        The emulator's FEM mesh (``[emulator]``); None: the description's.
    path : str or None
        Where the file was read from (not compared).
    source : dict
        The parsed TOML document (its hash is :attr:`sha256`; not compared).
    tilt_deg : float
        Base tilt (deg) about ``tilt_axis_W``; 0: level.
    tilt_axis_W : numpy.ndarray or None
        Unit tilt axis, shape (3,), in W.
    frame_rotation_deg : float
        Registration error of the mocap frame (deg) about ``frame_rotation_axis_W``.
    frame_rotation_axis_W : numpy.ndarray or None
        Unit axis, shape (3,), of that error.
    frame_offset_m : numpy.ndarray or None
        Registration offset of the mocap frame, shape (3,), in m.
    creep_fraction : float
        Share of each step taken by a third, creep mode (0: none).
    creep_tau_s : float or None
        Time constant (s) of the creep mode.
    law : str
        Material law, one of :data:`LAWS`.
    hyperfoam_mu_pa, hyperfoam_alpha, hyperfoam_beta : float or None
        The hyperfoam law's initial shear modulus (Pa), exponent and volumetric parameter.
    chambers : tuple of ChamberDefects
        One per pressure chamber of the robot, in its order (empty: a cable robot).
    """

    robot: str
    softness: float
    gradient: float
    gradient_direction_W: np.ndarray
    cables: tuple[CableDefects, ...]
    tau_fast_s: float
    tau_slow_s: float
    slow_fraction: float
    ticks_per_rev: int
    profile_velocity_rad_s: float
    frame_rate_hz: float
    noise_sigma_m: float
    dropout_rate_hz: float
    dropout_max_frames: int
    n_rings: int | None
    n_axial: int | None
    path: str | None = field(default=None, compare=False)
    source: dict = field(default_factory=dict, repr=False, compare=False)
    tilt_deg: float = 0.0
    tilt_axis_W: np.ndarray | None = None  # unit (3,)
    frame_rotation_deg: float = 0.0
    frame_rotation_axis_W: np.ndarray | None = None  # unit (3,)
    frame_offset_m: np.ndarray | None = None  # (3,) m
    creep_fraction: float = 0.0
    creep_tau_s: float | None = None
    law: str = "neo-hookean"
    hyperfoam_mu_pa: float | None = None
    hyperfoam_alpha: float | None = None
    hyperfoam_beta: float | None = None
    chambers: tuple[ChamberDefects, ...] = ()

    @property
    def sha256(self) -> str:
        """Hash of the parsed file (independent of comments and formatting)."""
        return hashlib.sha256(json.dumps(self.source, sort_keys=True).encode()).hexdigest()

    @property
    def slack_m(self) -> np.ndarray:
        return np.array([c.slack_m for c in self.cables])

    @property
    def play_m(self) -> np.ndarray:
        return np.array([c.play_m for c in self.cables])

    @property
    def R_tilt(self) -> np.ndarray | None:
        """Rotation (3, 3) of the base in the room (body -> W), or None when level."""
        return rotation(self.tilt_axis_W, self.tilt_deg) if self.tilt_deg else None

    @property
    def R_frame(self) -> np.ndarray | None:
        """Registration error (3, 3) of the motion capture's frame, or None when exact."""
        return rotation(self.frame_rotation_axis_W, self.frame_rotation_deg) if self.frame_rotation_deg else None

    @property
    def has_frame_offset(self) -> bool:
        return self.frame_offset_m is not None and bool(np.any(self.frame_offset_m != 0))


def rotation(axis, angle_deg: float) -> np.ndarray:
    """Right-handed rotation matrix (3, 3) by ``angle_deg`` about the unit ``axis`` (3,)
    (Rodrigues: R = cos a I + sin a [axis]x + (1 - cos a) axis axis^T)."""
    k = np.asarray(axis, dtype=float)
    a = math.radians(angle_deg)
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return math.cos(a) * np.eye(3) + math.sin(a) * K + (1.0 - math.cos(a)) * np.outer(k, k)


def _finite(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def num(table: dict, key: str, where: str, *, lo=None, hi=None, lo_open=False, integer=False):
    """The required number ``table[key]`` (``where``: its table, for the message), with
    ``lo <= v`` (``lo < v`` if ``lo_open``) and ``v < hi``."""
    if key not in table:
        raise DefectsError(f"missing field '{where}.{key}'")
    v = table[key]
    ok_type = isinstance(v, int) if integer else isinstance(v, (int, float))
    if isinstance(v, bool) or not ok_type or not math.isfinite(v):
        kind = "an integer" if integer else "a finite number"
        raise DefectsError(f"field '{where}.{key}' must be {kind}, got {v!r}")
    if lo is not None and (v <= lo if lo_open else v < lo):
        raise DefectsError(f"field '{where}.{key}' must be {'>' if lo_open else '>='} {lo}, got {v!r}")
    if hi is not None and v >= hi:
        raise DefectsError(f"field '{where}.{key}' must be < {hi}, got {v!r}")
    return int(v) if integer else float(v)


def ranged(table: dict, key: str, where: str, lo: float, hi: float, unit: str, *, lo_open=False, hi_open=False):
    """The required number ``table[key]`` in the interval lo..hi (closed unless ``*_open``);
    the message names the field and the allowed range."""
    v = table.get(key)
    shown = f"{'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}{unit}"
    if key not in table:
        raise DefectsError(f"missing field '{where}.{key}' (a number in {shown})")
    ok = _finite(v) and (v > lo if lo_open else v >= lo) and (v < hi if hi_open else v <= hi)
    if not ok:
        raise DefectsError(f"field '{where}.{key}' must be a finite number in {shown}, got {v!r}")
    return float(v)


def vec3(table: dict, key: str, where: str, *, unit: bool = False, norm_limit: float | None = None) -> np.ndarray:
    """The list of 3 finite numbers ``table[key]`` as (3,); ``unit``: a direction of nonzero
    length, returned normalised; ``norm_limit``: its length at most that."""
    v = table.get(key)
    if not isinstance(v, list) or len(v) != 3 or not all(_finite(c) for c in v):
        raise DefectsError(f"field '{where}.{key}' must be a list of 3 finite numbers, got {v!r}")
    a = np.asarray(v, dtype=float)
    n = float(np.linalg.norm(a))
    if unit:
        if not n > 1e-12:
            raise DefectsError(f"field '{where}.{key}' must be a direction of nonzero length, got {v!r}")
        return a / n
    if norm_limit is not None and n > norm_limit:
        raise DefectsError(f"field '{where}.{key}' must have length <= {norm_limit:g} m, got {n:.6g} m ({v!r})")
    return a
