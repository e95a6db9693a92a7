"""``SimRig``: the nominal FEM as a robot that reaches static equilibrium instantly.

This is the paper's "Sim Robot": no lag, no hysteresis, no noise. Each command is
solved by ``solve_static``, warm-started from the previous equilibrium, so a trajectory
of nearby commands costs a few Newton iterations per point.
"""

from __future__ import annotations

import numpy as np

from lab.description import RobotDescription
from lab.fem.model import ArmFEM
from lab.fem.solve.statics import solve_static
from lab.rig.base import MocapFrame, Rig


class SimRig(Rig):
    """Quasi-static nominal FEM behind the rig interface (virtual clock, exact tip and
    every marker: ``MocapFrame.markers_W``; a tension-controlled cable's input in N).

    Parameters
    ----------
    robot : RobotDescription
        The robot; the rig starts hanging under gravity with all cables at rest (u = 0).
    fem : ArmFEM, optional
        The model to solve; the nominal ``ArmFEM(robot)`` when omitted.
    frame_rate_hz : float
        Virtual motion-capture frame rate (Hz); each frame advances the clock 1/rate s.
    """

    kind = "sim"

    def __init__(self, robot: RobotDescription, fem: ArmFEM | None = None, frame_rate_hz: float = 120.0):
        super().__init__(robot, frame_rate_hz)
        self.fem = fem if fem is not None else ArmFEM(robot)
        self._t_s = 0.0
        self.solve_time_s = 0.0  # total FEM time spent, for reports
        self._q = self.fem.rest_q()
        self._send(np.zeros(robot.n_inputs))  # start hanging under gravity, cables at rest

    def _send(self, u_motor: np.ndarray) -> None:
        sol = solve_static(self.fem, u_motor, self._q)
        self._u, self._q, self._p_tip_W = u_motor.copy(), sol.q, sol.p_tip_W
        self._y_W = np.asarray(sol.y_W, dtype=float).reshape(-1, 3)
        self.solve_time_s += sol.time_s

    def present_u(self) -> np.ndarray:
        return self._u.copy()

    def now(self) -> float:
        return self._t_s

    def next_frame(self) -> MocapFrame:
        self._t_s += 1.0 / self.frame_rate_hz
        return MocapFrame(self._t_s, self._p_tip_W.copy(), self._y_W.copy())

    def describe(self) -> dict:
        """JSON-able description of this rig for dataset/report metadata.

        Returns
        -------
        dict
            The base description plus ``mesh_nodes``, the FEM mesh's node count.
        """
        return {**super().describe(), "mesh_nodes": int(self.fem.mesh.n_nodes)}
