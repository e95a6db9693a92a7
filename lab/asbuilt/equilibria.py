"""``EquilibriumCache``: the as-built FEM's equilibria for effective inputs, cached and warm-started.

The twin (:class:`lab.rig.twin.AsBuiltBody`) solves its FEM once per command for the
*effective* input state ``y`` (m,): what each cable really pulled in after friction play (m)
for a spool-angle cable, the held tension (N) for a tension-controlled tendon (no play). The
FEM is solved at the inputs ``u = y / scale`` (``scale``: the spool radius of an angle
cable, 1 for a tension), and each solution gives the tip and every marker of the robot
(``fem.marker_names``, the tip first).
"""

from __future__ import annotations

import time
from collections import OrderedDict

import numpy as np

from lab.errors import LabRuntimeError
from lab.fem.solve.statics import solve_static

__all__ = ["EquilibriumCache", "input_scale"]


def input_scale(robot):
    """What turns an effective input state into the FEM's input: ``u = y / scale``.

    Parameters
    ----------
    robot : RobotDescription
        The robot.

    Returns
    -------
    float or numpy.ndarray
        The spool radius (m) when every cable is angle-controlled (today's robots, a scalar);
        else per input (m,): the spool radius for an angle cable, 1 for a tension (N per N)
        and for a chamber (its pressure, Pa per Pa).
    """
    chambers = tuple(getattr(robot, "chambers", ()))
    if robot.all_angle and not chambers:
        return robot.spool_radius_m
    cables = [robot.spool_radius_m if c.control == "angle" else 1.0 for c in robot.cables]
    return np.array(cables + [1.0] * len(chambers), float)  # a chamber's input is its pressure (volume)


class EquilibriumCache:
    """Equilibria of an FEM for *effective* input states ``y`` (m,): cable contractions in m
    (angle cables), tensions in N (tension-controlled tendons).

    ``y`` is what the cables really pulled in (after friction play); the FEM is solved
    at the inputs ``y / scale`` (:func:`input_scale`). Each new equilibrium is warm-started
    from the nearest cached one, predicted forward with its sensitivity; the last
    ``max_entries`` are kept (least recently used dropped). Keys are ``y`` rounded to
    1e-9 (1 nm, 1 nN), so a repeated state (e.g. the reset) costs nothing.

    Parameters
    ----------
    fem : ArmFEM
        The model to solve (its ``robot`` gives the inputs' scale).
    max_entries : int
        How many equilibria are kept.
    """

    def __init__(self, fem, max_entries: int = 256):
        self.fem = fem
        self.max_entries = int(max_entries)
        self._r = input_scale(fem.robot)
        self._entries: OrderedDict[tuple, tuple] = OrderedDict()  # key -> (u_eff, q, dq_du, p_tip_W, y_W)
        self.n_solves = 0
        self.solve_time_s = 0.0

    def tip(self, contraction_m) -> np.ndarray:
        """Equilibrium tip for an effective input state.

        Parameters
        ----------
        contraction_m : array_like
            Effective input state y, shape (m,): contractions in m, tensions in N.

        Returns
        -------
        numpy.ndarray
            The tip p_tip_W, shape (3,), in m in the FEM's (body) frame.
        """
        return self._entry(contraction_m)[3].copy()

    def markers(self, contraction_m) -> np.ndarray:
        """Equilibrium positions of every marker for an effective input state.

        Parameters
        ----------
        contraction_m : array_like
            Effective input state y, shape (m,): contractions in m, tensions in N.

        Returns
        -------
        numpy.ndarray
            Every marker (``fem.marker_names``, the tip first), shape (K, 3), in m in the
            FEM's (body) frame; row 0 is :meth:`tip`.
        """
        entry = self._entry(contraction_m)
        y = np.array(entry[4], dtype=float).reshape(-1, 3)
        y[0] = entry[3]
        return y

    def _entry(self, contraction_m) -> tuple:
        y = np.asarray(contraction_m, dtype=float)
        key = tuple(np.rint(y * 1e9).astype(np.int64).tolist())
        if key in self._entries:
            self._entries.move_to_end(key)
            return self._entries[key]
        u_eff = y / self._r
        t0 = time.perf_counter()
        sol = self._solve(u_eff)
        self.solve_time_s += time.perf_counter() - t0
        self.n_solves += 1
        y_W = sol.y_W if sol.y_W is not None else self.fem.observe(self.fem.to_nodes(sol.q))
        entry = (u_eff, sol.q, sol.dq_du, sol.p_tip_W, y_W)
        self._entries[key] = entry
        if len(self._entries) > self.max_entries:
            self._entries.popitem(last=False)
        return entry

    def _solve(self, u_eff: np.ndarray):
        kw = dict(sensitivity="reuse", raise_on_failure=False, check_command=False)
        start = None
        if self._entries:
            entries = list(self._entries.values())
            dist = np.abs(np.array([e[0] for e in entries]) - u_eff).sum(axis=1)  # L1 to each, in order
            start = entries[int(np.argmin(dist))]
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
                f"as-built FEM: no equilibrium found for effective inputs "
                f"{u_eff.tolist()} (rad or N; {prev.status}, residual {prev.grad_norm_n:.3g} N)"
            )
        return prev
