"""The emulated as-built robot: ``AsBuiltBody`` (the arm in time) and ``TwinRig``.

``AsBuiltBody`` is a :class:`~lab.rig.base.Body` that the twin rig and the hardware
emulators drive. From a command to the tip: motor goals rounded to encoder ticks and
reached at the profile velocity; a Prandtl play of half-width ``h`` on each cable's
contraction (hysteresis, erased by the capture protocol's reset); the as-built FEM solved
once per command (:class:`~lab.asbuilt.arm.EquilibriumCache`), its equilibrium moving
linearly while the motors turn; the foam's lag, two first-order modes integrated
exactly (three with the defects file's creep); and where the motion capture sees the tip
(:meth:`AsBuiltBody.report`: the base's tilt, the mocap's frame error). ``TwinRig`` puts
the body on a virtual clock advanced one motion-capture frame per ``next_frame()`` and
observes the tip through ``MocapModel`` (Gaussian noise and occlusion bursts, NaN
frames; :mod:`.mocap_model`). Deterministic for a given seed. :class:`FamilyTwinRig` is the twin on a member of a
family of as-built robots (:class:`lab.asbuilt.Family`). The model step by step: ``docs/design/rig.md``.
"""

from __future__ import annotations

import math

import numpy as np

from lab.asbuilt.arm import Defects, EquilibriumCache, as_built_fem, load_defects
from lab.asbuilt.draw import check_seed
from lab.asbuilt.family import RANDOM, Family
from lab.description import RobotDescription
from lab.errors import InputError
from lab.rig.base import Body, MocapFrame, Rig, RigError
from lab.rig.mocap_model import MocapModel


class AsBuiltBody(Body):
    """The as-built arm in time (see the module docstring).

    Parameters
    ----------
    robot : RobotDescription
        The nominal robot (cables, spool radius, limits).
    defects : Defects or str or None
        The as-built defects: a :class:`Defects`, a TOML path, or None for the robot's
        shipped default.
    n_rings, n_axial : int, optional
        Override the FEM mesh's rings and axial layers (coarse meshes for tests).
    """

    def __init__(
        self,
        robot: RobotDescription,
        defects: Defects | str | None = None,
        *,
        n_rings: int | None = None,
        n_axial: int | None = None,
    ):
        self.robot = robot
        self.defects = defects if isinstance(defects, Defects) else load_defects(defects, robot)
        self.fem = as_built_fem(robot, self.defects, n_rings=n_rings, n_axial=n_axial)
        self.equilibria = EquilibriumCache(self.fem)
        self.n_motors = robot.n_cables
        #: motor speed (rad/s) used for the next command; the XM430 emulator may set it
        self.profile_velocity_rad_s = self.defects.profile_velocity_rad_s
        #: or each motor's (n_motors,) rad/s (the XM430 emulator's servos); None: all at the above
        self.motor_speeds_rad_s: np.ndarray | None = None
        d = self.defects
        self._r = robot.spool_radius_m
        self._h = d.play_m
        self._tick = 2 * math.pi / d.ticks_per_rev if d.ticks_per_rev else 0.0
        if d.creep_fraction > 0:  # a third, slow mode (creep)
            self._w = np.array([1.0 - d.slow_fraction - d.creep_fraction, d.slow_fraction, d.creep_fraction])
            self._tau = np.array([d.tau_fast_s, d.tau_slow_s, d.creep_tau_s])
        else:
            self._w = np.array([1.0 - d.slow_fraction, d.slow_fraction])
            self._tau = np.array([d.tau_fast_s, d.tau_slow_s])
        R_tilt, R_frame = d.R_tilt, d.R_frame
        self._R_report = R_tilt if R_frame is None else (R_frame if R_tilt is None else R_frame @ R_tilt)
        self._offset_report = d.frame_offset_m if d.has_frame_offset else None
        zero = np.zeros(self.n_motors)
        p_rest = self.equilibria.tip(zero)
        # Current motion segment, from t0: motors u0 -> goal at speed v, cables from y0,
        # equilibrium p0 -> p1 linearly over T seconds.
        self._t0, self._u0, self._goal, self._v = 0.0, zero.copy(), zero.copy(), self.profile_velocity_rad_s
        self._y0, self._p0, self._p1, self._T = zero.copy(), p_rest, p_rest, 0.0
        self._t = 0.0
        self._z = np.stack([p_rest] * len(self._w))  # lag modes (2 or 3, 3) in the body frame, settled

    # ---------------------------------------------------------------- Body interface
    def command(self, u_goal_rad: np.ndarray, t_s: float) -> None:
        """New goal motor angles from ``t_s`` on (any finite angles; the rig, not the
        body, enforces the robot's range and safety rule).

        Parameters
        ----------
        u_goal_rad : numpy.ndarray
            Goal motor angles, shape (n_motors,), in rad; rounded to encoder ticks and
            reached at the profile velocity.
        t_s : float
            Time (s, body clock) from which the goal holds; not before the body's time.
        """
        goal = np.asarray(u_goal_rad, dtype=float)
        if goal.shape != (self.n_motors,) or not np.all(np.isfinite(goal)):
            raise InputError(f"expected {self.n_motors} finite motor angles, got {goal!r}")
        self._advance(t_s)
        u_now, y_now, p_now = self._motors(self._t), self._contraction(self._t), self._input(self._t)
        goal = self._quantise(goal)
        y_end = np.clip(y_now, self._r * goal - self._h, self._r * goal + self._h)
        p_end = self.equilibria.tip(y_end)
        v = float(self.profile_velocity_rad_s) if self.motor_speeds_rad_s is None else self.motor_speeds_rad_s
        if not np.all(np.asarray(v) > 0):
            raise InputError(f"motor speeds must be positive, got {v}")
        self._t0, self._u0, self._goal, self._v = self._t, u_now, goal, v
        self._y0, self._p0, self._p1 = y_now, p_now, p_end
        travel = np.abs(goal - u_now)
        k = int(np.argmax(travel))  # the equilibrium ramps over the time of the farthest move
        self._T = float(travel[k] / (v if np.ndim(v) == 0 else v[k]))

    def state(self, t_s: float) -> tuple[np.ndarray, np.ndarray]:
        """The motors and the tip at ``t_s``, after integrating the lag modes up to then.

        Parameters
        ----------
        t_s : float
            Time (s, body clock); not before the body's time.

        Returns
        -------
        u_present_rad : numpy.ndarray
            Present motor angles, shape (n_motors,), in rad, in whole encoder ticks.
        p_tip_W : numpy.ndarray
            Tip, shape (3,), in m, where the motion capture sees it before its noise
            (:meth:`report` of the body's tip).
        """
        self._advance(t_s)
        return self._quantise(self._motors(self._t)), self.report(self._w @ self._z)

    # ---------------------------------------------------------------- helpers
    @property
    def time_s(self) -> float:
        """The body's clock: the latest time it was advanced to, s."""
        return self._t

    @property
    def contraction_m(self) -> np.ndarray:
        """Effective cable contractions y (n_motors,) m after the play, at the body's time."""
        return self._contraction(self._t)

    def contraction_from_reset(self, u_motor) -> np.ndarray:
        """Effective contractions when ``u_motor`` is approached from the reset state
        (every cable released to y = +h): ``max(h, r u - h)``.

        Parameters
        ----------
        u_motor : array_like
            Motor angles, shape (n_motors,), in rad (rounded to encoder ticks).

        Returns
        -------
        numpy.ndarray
            Cable contractions y after the play, shape (n_motors,), in m.
        """
        return np.maximum(self._h, self._r * self._quantise(np.asarray(u_motor, float)) - self._h)

    def quasi_static_tip(self, u_motor) -> np.ndarray:
        """Noise-free settled tip for ``u_motor`` reached after a reset: the quasi-static
        map the capture protocol measures (:meth:`report`, noise-free).

        Parameters
        ----------
        u_motor : array_like
            Motor angles, shape (n_motors,), in rad.

        Returns
        -------
        numpy.ndarray
            Settled tip p_tip_W, shape (3,), in m in the motion capture's frame W.
        """
        return self.report(self.equilibria.tip(self.contraction_from_reset(u_motor)))

    def report(self, p_body: np.ndarray) -> np.ndarray:
        """Where the motion capture reports a point of the body frame (the FEM's):
        ``R_err (R_tilt p_body) + frame_offset_m`` -- the base tilted in the room (about its
        origin), the room's frame registered with an error. Without those defects, ``p_body``
        itself (bit for bit).

        Parameters
        ----------
        p_body : numpy.ndarray
            A point, shape (3,), in m in the body (FEM) frame.

        Returns
        -------
        numpy.ndarray
            The point, shape (3,), in m in the motion capture's frame W.
        """
        p = p_body if self._R_report is None else self._R_report @ p_body
        return p if self._offset_report is None else p + self._offset_report

    def _quantise(self, u: np.ndarray) -> np.ndarray:
        return np.rint(u / self._tick) * self._tick if self._tick else np.array(u, dtype=float)

    def _motors(self, t: float) -> np.ndarray:
        step = self._v * (t - self._t0)
        return self._u0 + np.clip(self._goal - self._u0, -step, step)

    def _contraction(self, t: float) -> np.ndarray:
        # Each motor moves monotonically within a segment, so the play output is a clip.
        x = self._r * self._motors(t)
        return np.clip(self._y0, x - self._h, x + self._h)

    def _input(self, t: float) -> np.ndarray:
        if self._T <= 0 or t >= self._t0 + self._T:
            return self._p1
        return self._p0 + (self._p1 - self._p0) * ((t - self._t0) / self._T)

    def _advance(self, t_s: float) -> None:
        """Integrate the lag modes exactly from the body's time to ``t_s``."""
        t_s = float(t_s)
        if t_s < self._t - 1e-9:
            raise InputError(f"time went backwards: {t_s} s after {self._t} s")
        t_ramp_end = self._t0 + self._T
        while t_s > self._t:
            if self._t < t_ramp_end:  # equilibrium moving linearly
                t_b, slope = min(t_s, t_ramp_end), (self._p1 - self._p0) / self._T
            else:
                t_b, slope = t_s, 0.0
            a, s = self._input(self._t), t_b - self._t
            decay = np.exp(-s / self._tau)[:, None]
            lag = slope * self._tau[:, None]
            self._z = a + slope * s - lag + (self._z - a + lag) * decay
            self._t = t_b


class TwinRig(Rig):
    """The emulated as-built robot behind the rig interface, on a virtual clock.

    Parameters
    ----------
    robot : RobotDescription
        The nominal robot.
    defects : Defects or str or None
        The as-built defects: a :class:`Defects`, a TOML path, or None (the robot's
        shipped default); ignored when ``body`` is given.
    seed : int
        Seed of the motion capture's noise and dropouts.
    body : AsBuiltBody, optional
        An existing body to drive (its defects are then used; its clock may be ahead).
    """

    kind = "twin"

    def __init__(
        self,
        robot: RobotDescription,
        defects: Defects | str | None = None,
        seed: int = 0,
        *,
        body: AsBuiltBody | None = None,
    ):
        self.body = body if body is not None else AsBuiltBody(robot, defects)
        self.defects = self.body.defects
        super().__init__(robot, self.defects.frame_rate_hz)
        self.seed = int(seed)
        self.mocap = MocapModel.from_defects(self.defects, self.seed)
        self._frame = 0
        self._t_start_s = self.body.time_s  # a reused body may already be ahead

    def _send(self, u_motor: np.ndarray) -> None:
        try:
            self.body.command(u_motor, self._body_time())
        except RuntimeError as err:  # the as-built FEM found no equilibrium
            raise RigError(f"twin: {err}") from err

    def present_u(self) -> np.ndarray:
        return self.body.state(self._body_time())[0]

    def now(self) -> float:
        return self._frame / self.frame_rate_hz

    def _body_time(self) -> float:
        return self._t_start_s + self.now()

    def next_frame(self) -> MocapFrame:
        self._frame += 1
        p_true = self.body.state(self._body_time())[1]
        return MocapFrame(self.now(), self.mocap.observe(p_true))

    def describe(self) -> dict:
        """JSON-able description of this rig for dataset/report metadata.

        Returns
        -------
        dict
            The base description plus the mocap ``seed``, the ``defects`` (path, SHA-256,
            values) and the FEM ``mesh`` (node and tet counts).
        """
        d, fem = self.defects, self.body.fem
        return {
            **super().describe(),
            "seed": self.seed,
            "defects": {"path": d.path, "sha256": d.sha256, "values": d.source},
            "mesh": {"n_nodes": int(fem.mesh.n_nodes), "n_tets": int(len(fem.mesh.tets))},
        }


class FamilyTwinRig(TwinRig):
    """The twin rig on member ``robot_seed`` of a family (``--rig twin:random:SEED``, ``twin:foam:SEED``).

    ``describe()`` records the family's label, the robot seed, the generator and its
    version (:meth:`lab.asbuilt.Family.describe`), so that a dataset says which robot it
    came from.

    Parameters
    ----------
    robot : RobotDescription
        The nominal robot.
    robot_seed : int
        The member of the family, an integer >= 0.
    seed : int
        The motion-capture noise seed, as for :class:`TwinRig`.
    family : Family
        The family (:data:`lab.asbuilt.RANDOM` or :data:`lab.asbuilt.FOAM`).
    **mesh
        ``n_rings``/``n_axial``: the emulator mesh, overriding the member's own.
    """

    def __init__(self, robot: RobotDescription, robot_seed: int, seed: int = 0, *, family: Family = RANDOM, **mesh):
        self.robot_seed = check_seed(robot_seed)
        self.family = family
        body = AsBuiltBody(robot, family.defects(robot, self.robot_seed, **mesh))
        super().__init__(robot, seed=seed, body=body)

    def describe(self) -> dict:
        """The twin's record (:meth:`TwinRig.describe`) with the family's (:meth:`lab.asbuilt.Family.describe`).

        Returns
        -------
        dict
            JSON-ready metadata of the rig.
        """
        return {**super().describe(), **self.family.describe(self.robot_seed)}


def quasi_static_tips(body, u_motor, noise_sigma_m: float = 0.0, seed: int = 0) -> np.ndarray:
    """Settled tips of ``body`` for commands ``u_motor``, each reached after the protocol's
    reset, plus Gaussian noise: what ``capture`` measures once the lag has died out,
    without emulating the waiting.

    Parameters
    ----------
    body : AsBuiltBody
        The arm (anything with ``quasi_static_tip(u)``).
    u_motor : array_like
        Commands, shape (N, m) (or (m,) for one), in rad.
    noise_sigma_m : float
        Gaussian noise per axis (m); 0 for the noise-free tips.
    seed : int
        Seed of the noise.

    Returns
    -------
    numpy.ndarray
        Settled tips p_tip_W, shape (N, 3), in m in the motion capture's frame W.
    """
    u = np.atleast_2d(np.asarray(u_motor, float))
    tips = np.array([body.quasi_static_tip(ui) for ui in u])
    if noise_sigma_m > 0:
        tips += np.random.default_rng(seed).normal(0.0, noise_sigma_m, tips.shape)
    return tips
