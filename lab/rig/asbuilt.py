"""The as-built arm: a defect file the nominal model does not know, and its statics.

A *defects file* (TOML, user-editable) says how the robot that was actually built
differs from its description (``[material]`` softness and casting gradient,
``[[cables]]`` eyelet shifts, slack and play) and how the emulated rig (``twin``) behaves
in time (``[lag]``, ``[motors]``, ``[mocap]``; ``[emulator]`` an optional FEM mesh).
:func:`load_defects` validates every field and raises :class:`DefectsError` naming the
bad one; the shipped default for a robot is ``lab/rig/defects/<robot>.toml``.
:func:`as_built_fem` is the FEM of the as-built arm and :class:`EquilibriumCache` solves
it for effective cable contractions, warm-started from the nearest cached equilibrium.
Every field is described in ``docs/design/rig.md``.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import time
from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from lab.description import RobotDescription, check_fields, read_toml
from lab.errors import InputError, LabRuntimeError
from lab.fem.energy import ArmFEM
from lab.fem.mesh import cylinder_mesh
from lab.fem.statics import solve_static

FORMAT_VERSION = 1
DEFECTS_DIR = Path(__file__).with_name("defects")


class DefectsError(InputError):
    """A defects file is missing a field, has an invalid value, or does not fit the robot."""


@dataclass(frozen=True)
class CableDefects:
    """As-built cable ``name``: eyelet shift ``via_shift_m`` (3,) m in frame W, extra free
    length ``slack_m`` (m), play half-width ``play_m`` (m of contraction)."""

    name: str
    via_shift_m: np.ndarray
    slack_m: float
    play_m: float


@dataclass(frozen=True)
class Defects:
    """A validated defects file (see the module docstring for the meaning of each field)."""

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


def _num(table: dict, key: str, where: str, *, lo=None, hi=None, lo_open=False, integer=False):
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


def _vec3(table: dict, key: str, where: str) -> np.ndarray:
    v = table.get(key)
    if (
        not isinstance(v, list)
        or len(v) != 3
        or not all(isinstance(c, (int, float)) and not isinstance(c, bool) and math.isfinite(c) for c in v)
    ):
        raise DefectsError(f"field '{where}.{key}' must be a list of 3 finite numbers, got {v!r}")
    return np.asarray(v, dtype=float)


#: The fields of each table of a defects file.
DEFECTS_FIELDS = {
    "": {"format_version", "robot", "material", "cables", "lag", "motors", "mocap", "emulator"},
    "material": {"softness", "gradient", "gradient_direction"},
    "cables": {"name", "via_shift_m", "slack_m", "play_m"},
    "lag": {"tau_fast_s", "tau_slow_s", "slow_fraction"},
    "motors": {"ticks_per_rev", "profile_velocity_rad_s"},
    "mocap": {"frame_rate_hz", "noise_sigma_m", "dropout_rate_hz", "dropout_max_frames"},
    "emulator": {"n_rings", "n_axial"},
}


def _table(data: dict, key: str) -> dict:
    t = data.get(key)
    if t is None:
        raise DefectsError(f"missing table [{key}]")
    return check_fields(t, DEFECTS_FIELDS[key], key, DefectsError)


def parse_defects(data: dict, robot: RobotDescription, path: str | None = None) -> Defects:
    """Validate a parsed defects TOML document against ``robot`` and build :class:`Defects`."""
    check_fields(data, DEFECTS_FIELDS[""], "", DefectsError)
    if data.get("format_version") != FORMAT_VERSION:
        raise DefectsError(f"field 'format_version' must be {FORMAT_VERSION}, got {data.get('format_version')!r}")
    if data.get("robot") != robot.name:
        raise DefectsError(f"field 'robot' is {data.get('robot')!r} but the robot is {robot.name!r}")
    mat = _table(data, "material")
    softness = _num(mat, "softness", "material", lo=0.0, lo_open=True)
    gradient = _num(mat, "gradient", "material", lo=0.0, hi=1.0)
    direction = _vec3(mat, "gradient_direction", "material")
    if abs(direction[0]) > 1e-12 or np.linalg.norm(direction) == 0:
        raise DefectsError(
            "field 'material.gradient_direction' must be a nonzero direction across the "
            f"section (x component 0: the body axis is +x), got {direction.tolist()}"
        )
    entries = data.get("cables")
    if not isinstance(entries, list) or len(entries) != robot.n_cables:
        raise DefectsError(
            f"[[cables]] must have one table per cable of {robot.name} "
            f"({robot.n_cables}), got {len(entries) if isinstance(entries, list) else 0}"
        )
    cables = []
    for i, (entry, cable) in enumerate(zip(entries, robot.cables)):
        where = f"cables[{i}]"
        check_fields(entry, DEFECTS_FIELDS["cables"], where, DefectsError)
        if entry.get("name") != cable.name:
            got = entry.get("name") if isinstance(entry, dict) else entry
            raise DefectsError(f"field '{where}.name' must be {cable.name!r} (the description's order), got {got!r}")
        cables.append(
            CableDefects(
                cable.name,
                _vec3(entry, "via_shift_m", where),
                _num(entry, "slack_m", where, lo=0.0),
                _num(entry, "play_m", where, lo=0.0),
            )
        )
    lag = _table(data, "lag")
    tau_fast = _num(lag, "tau_fast_s", "lag", lo=0.0, lo_open=True)
    tau_slow = _num(lag, "tau_slow_s", "lag", lo=0.0, lo_open=True)
    if tau_slow < tau_fast:
        raise DefectsError(f"field 'lag.tau_slow_s' ({tau_slow}) must be >= 'lag.tau_fast_s' ({tau_fast})")
    motors, mocap = _table(data, "motors"), _table(data, "mocap")
    emulator = check_fields(data.get("emulator", {}), DEFECTS_FIELDS["emulator"], "emulator", DefectsError)
    mesh = {
        k: (_num(emulator, k, "emulator", lo=1, integer=True) if k in emulator else None)
        for k in ("n_rings", "n_axial")
    }
    return Defects(
        robot=robot.name,
        softness=softness,
        gradient=gradient,
        gradient_direction_W=direction / np.linalg.norm(direction),
        cables=tuple(cables),
        tau_fast_s=tau_fast,
        tau_slow_s=tau_slow,
        slow_fraction=_num(lag, "slow_fraction", "lag", lo=0.0, hi=1.0),
        ticks_per_rev=_num(motors, "ticks_per_rev", "motors", lo=0, integer=True),
        profile_velocity_rad_s=_num(motors, "profile_velocity_rad_s", "motors", lo=0.0, lo_open=True),
        frame_rate_hz=_num(mocap, "frame_rate_hz", "mocap", lo=0.0, lo_open=True),
        noise_sigma_m=_num(mocap, "noise_sigma_m", "mocap", lo=0.0),
        dropout_rate_hz=_num(mocap, "dropout_rate_hz", "mocap", lo=0.0),
        dropout_max_frames=_num(mocap, "dropout_max_frames", "mocap", lo=1, integer=True),
        n_rings=mesh["n_rings"],
        n_axial=mesh["n_axial"],
        path=path,
        source=data,
    )


def default_defects_path(robot: RobotDescription) -> Path:
    """The shipped defects file of ``robot``: ``lab/rig/defects/<robot.name>.toml``."""
    return DEFECTS_DIR / f"{robot.name}.toml"


def load_defects(path: str | Path | None, robot: RobotDescription) -> Defects:
    """Load and validate a defects file (``None``: the shipped default for ``robot``)."""
    shown = None
    if path is None:
        path = default_defects_path(robot)
        if not path.exists():
            raise DefectsError(
                f"no shipped defects file for robot {robot.name!r} ({path}); "
                f"write one and pass it as --rig twin:DEFECTS.toml"
            )
        shown = f"lab/rig/defects/{path.name}"  # recorded relative to the repository
    path = Path(path)
    data = read_toml(path, DefectsError, "defects file")
    try:
        return parse_defects(data, robot, shown or str(path))
    except DefectsError as err:
        raise DefectsError(f"{path}: {err}") from None


def as_built_robot(robot: RobotDescription, defects: Defects) -> RobotDescription:
    """The description with every cable's via points moved by its ``via_shift_m``."""
    cables = tuple(
        dataclasses.replace(c, via_points_m=c.via_points_m + d.via_shift_m)
        for c, d in zip(robot.cables, defects.cables)
    )
    for i, c in enumerate(cables):
        r = np.hypot(c.via_points_m[:, 1], c.via_points_m[:, 2])
        if (
            np.any(r > robot.radius_m)
            or np.any(c.via_points_m[:, 0] <= 0)
            or np.any(c.via_points_m[:, 0] > robot.length_m)
            or np.any(np.diff(c.via_points_m[:, 0]) <= 0)
        ):
            raise DefectsError(
                f"field 'cables[{i}].via_shift_m' moves eyelets of {c.name!r} out of the body "
                f"(radius {robot.radius_m} m, 0 < x <= {robot.length_m} m, increasing x)"
            )
    return dataclasses.replace(robot, cables=cables)


def youngs_modulus_per_tet(robot: RobotDescription, defects: Defects, tet_centroids_W: np.ndarray) -> np.ndarray:
    """As-built Young's modulus (M,) Pa of tets with centroids (M, 3) m."""
    s = np.clip(tet_centroids_W @ defects.gradient_direction_W / robot.radius_m, -1.0, 1.0)
    return robot.youngs_modulus_pa * defects.softness * (1.0 + defects.gradient * s)


def as_built_fem(
    robot: RobotDescription, defects: Defects, *, n_rings: int | None = None, n_axial: int | None = None
) -> ArmFEM:
    """The FEM of the as-built arm (moved eyelets, softer graded foam, slack cables).

    Mesh resolution: the arguments, else the defects file's ``[emulator]``, else the
    description's."""
    built = as_built_robot(robot, defects)
    n_rings = n_rings or defects.n_rings or robot.n_rings
    n_axial = n_axial or defects.n_axial or robot.n_axial
    mesh = cylinder_mesh(robot.length_m, robot.radius_m, n_rings, n_axial)
    centroids = mesh.X_W[mesh.tets].mean(axis=1)
    try:
        return ArmFEM(
            built,
            mesh,
            youngs_modulus_pa=youngs_modulus_per_tet(robot, defects, centroids),
            cable_slack_m=defects.slack_m,
        )
    except ValueError as err:  # an eyelet between the polygonal mesh boundary and the radius
        raise DefectsError(
            f"as-built eyelets do not fit the {n_rings}-ring mesh, whose polygonal section "
            f"is smaller than the radius: {err}; shift them less, or use more rings"
        ) from None


class EquilibriumCache:
    """Tip equilibria of an FEM for *effective* cable contractions ``y`` (m,) m.

    ``y`` is what the cables really pulled in (after friction play); the FEM is solved
    at the motor angles ``y / spool_radius``. Each new equilibrium is warm-started from
    the nearest cached one, predicted forward with its sensitivity; the last
    ``max_entries`` are kept (least recently used dropped). Keys are ``y`` rounded to
    1 nm, so a repeated state (e.g. the reset) costs nothing.
    """

    def __init__(self, fem: ArmFEM, max_entries: int = 256):
        self.fem = fem
        self.max_entries = int(max_entries)
        self._r = fem.robot.spool_radius_m
        self._entries: OrderedDict[tuple, tuple] = OrderedDict()  # key -> (u_eff, q, dq_du, p_tip_W)
        self.n_solves = 0
        self.solve_time_s = 0.0

    def tip(self, contraction_m) -> np.ndarray:
        """Equilibrium tip position p_tip_W (3,) m for effective contractions (m,) m."""
        y = np.asarray(contraction_m, dtype=float)
        key = tuple(np.rint(y * 1e9).astype(np.int64).tolist())
        if key in self._entries:
            self._entries.move_to_end(key)
            return self._entries[key][3].copy()
        u_eff = y / self._r
        t0 = time.perf_counter()
        sol = self._solve(u_eff)
        self.solve_time_s += time.perf_counter() - t0
        self.n_solves += 1
        self._entries[key] = (u_eff, sol.q, sol.dq_du, sol.p_tip_W)
        if len(self._entries) > self.max_entries:
            self._entries.popitem(last=False)
        return sol.p_tip_W.copy()

    def _solve(self, u_eff: np.ndarray):
        kw = dict(sensitivity="reuse", raise_on_failure=False, check_command=False)
        start = None
        if self._entries:
            keys = list(self._entries)
            dist = [np.abs(self._entries[k][0] - u_eff).sum() for k in keys]
            start = self._entries[keys[int(np.argmin(dist))]]
        if start is not None and start[2] is not None:
            sol = solve_static(self.fem, u_eff, start[1] + start[2] @ (u_eff - start[0]), **kw)
            if sol.converged:
                return sol
        sol = solve_static(self.fem, u_eff, **kw)  # cold start from rest
        if sol.converged:
            return sol
        # Continuation from rest in small steps for a far, hard command.
        prev = solve_static(self.fem, np.zeros_like(u_eff), **kw)
        for a in np.linspace(0.1, 1.0, 10):
            prev = solve_static(self.fem, a * u_eff, prev.q, **kw)
            if not prev.converged:
                break
        if not prev.converged:
            raise LabRuntimeError(
                f"as-built FEM: no equilibrium found for effective motor angles "
                f"{u_eff.tolist()} rad ({prev.status}, residual {prev.grad_norm_n:.3g} N)"
            )
        return prev
