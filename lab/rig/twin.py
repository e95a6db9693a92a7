"""The emulated as-built robot behind the rig interface: ``TwinRig`` and ``FamilyTwinRig``.

``TwinRig`` puts an :class:`~lab.rig.asbuilt_body.AsBuiltBody` (the arm in time: motors,
play, the as-built FEM's equilibria, the foam's lag, where the motion capture sees each
marker) on a virtual clock advanced one motion-capture frame per ``next_frame()`` and
observes the tip through ``MocapModel`` (Gaussian noise and occlusion bursts, NaN frames;
:mod:`.mocap_model`); a robot with ``[[markers]]`` is observed at every marker
(``MocapFrame.markers_W``, the tip first, each with its own noise, all hidden together
during an occlusion), its tip exactly as before. Deterministic for a given seed.
:class:`FamilyTwinRig` is the twin on a member of a family of as-built robots
(:class:`lab.asbuilt.Family`). A robot driven by pressure chambers gets pressure regulators
instead of servos (:func:`emulated_body`, :class:`~lab.rig.pneumatic_body.PneumaticBody`).
The model step by step: ``docs/design/rig.md``.
"""

from __future__ import annotations

import numpy as np

from lab.asbuilt.arm import Defects
from lab.asbuilt.draw import check_seed
from lab.asbuilt.family import RANDOM, Family
from lab.data.chunks import nearest_walk
from lab.description import RobotDescription
from lab.rig.asbuilt_body import AsBuiltBody
from lab.rig.base import MocapFrame, Rig, RigError
from lab.rig.mocap_model import MocapModel
from lab.rig.pneumatic_body import PneumaticBody


def emulated_body(robot: RobotDescription, defects: Defects | str | None = None, **mesh) -> AsBuiltBody | PneumaticBody:
    """The emulated as-built body of ``robot``: servos and cables, or pressure regulators.

    Parameters
    ----------
    robot : RobotDescription
        The nominal robot.
    defects : Defects or str or None
        The as-built defects (a :class:`Defects`, a TOML path, or None: the shipped default).
    **mesh
        ``n_rings``/``n_axial`` mesh overrides (a cable arm's).

    Returns
    -------
    AsBuiltBody or PneumaticBody
        :class:`~lab.rig.pneumatic_body.PneumaticBody` for a robot with chambers (its inputs
        are pressures, Pa), else :class:`~lab.rig.asbuilt_body.AsBuiltBody` exactly as before.
    """
    if getattr(robot, "chambers", ()):
        return PneumaticBody(robot, defects, **mesh)
    return AsBuiltBody(robot, defects, **mesh)


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
    body : AsBuiltBody or PneumaticBody, optional
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
        self.body = body if body is not None else emulated_body(robot, defects)
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
        if len(self.body.marker_names) == 1:  # the tip alone, as always
            p_true = self.body.state(self._body_time())[1]
            return MocapFrame(self.now(), self.mocap.observe(p_true))
        seen = self.mocap.observe_markers(self.body.markers(self._body_time()))
        return MocapFrame(self.now(), seen[0], seen)

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
    """The twin rig on member ``robot_seed`` of a family (``--rig twin:random|foam|pneumatic:SEED``).

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
        The family (:data:`lab.asbuilt.RANDOM`, :data:`lab.asbuilt.FOAM` or :data:`lab.asbuilt.PNEUMATIC`).
    **mesh
        ``n_rings``/``n_axial``: the emulator mesh, overriding the member's own.
    """

    def __init__(self, robot: RobotDescription, robot_seed: int, seed: int = 0, *, family: Family = RANDOM, **mesh):
        self.robot_seed = check_seed(robot_seed)
        self.family = family
        body = emulated_body(robot, family.defects(robot, self.robot_seed, **mesh))
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
    without emulating the waiting. The equilibria are solved along a nearest-neighbour walk
    through the commands (:func:`lab.data.nearest_walk`), each warm-started from a near one;
    the tips and their noise come in the commands' order.

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
    tips = np.empty((len(u), 3))
    for i in nearest_walk(u):
        tips[i] = body.quasi_static_tip(u[i])
    if noise_sigma_m > 0:
        tips += np.random.default_rng(seed).normal(0.0, noise_sigma_m, tips.shape)
    return tips
