"""A trajectory followed by several markers at once: each shifted by its rest offset from the tip.

A trajectory is a path of the tip (N, 3) m. With ``IKConfig.markers`` other than the tip
alone, every listed marker follows the trajectory translated by its offset from the tip
at rest -- the positions the forward map the IK solves through predicts at the lowest
command (``commands.lo``: every cable at rest, under gravity) -- so the listed markers move
together as a rigid copy of their rest layout along the path. :class:`OffsetSolver` turns
the tip targets into the (N, 3M) targets of the M markers and reports, as the predicted
point of each target, the first listed marker's prediction shifted back by its offset (the
tip's position when that marker is on its path). The rig's measurement stays the tip's.
"""

from __future__ import annotations

import numpy as np

from lab.control.ik import check_targets
from lab.control.markers import forward_markers, marker_rows
from lab.control.soft_ik import FEMForwardMap
from lab.errors import InputError

__all__ = ["OffsetSolver", "rest_offsets", "with_marker_offsets"]


def rest_offsets(full_forward, markers, u_rest) -> np.ndarray:
    """Each marker's offset from the tip at rest, as a forward map of every marker predicts it.

    Parameters
    ----------
    full_forward : object
        A forward map of all the robot's markers (tip first).
    markers : tuple of str
        The markers driven.
    u_rest : array_like
        The rest command (m,), each input in its unit.

    Returns
    -------
    numpy.ndarray
        Offsets (M, 3), m.
    """
    names = forward_markers(full_forward)
    y = np.asarray(full_forward.predict(np.asarray(u_rest, float)[None]), float).reshape(-1)
    if not np.all(np.isfinite(y)):
        raise InputError("the forward map gives no finite marker positions at rest: no offsets to follow with")
    rows = marker_rows(names, markers, "the forward map").reshape(-1, 3)
    return y[rows] - y[:3]


class OffsetSolver:
    """An :class:`lab.control.ik.IKSolver` of M markers that follows tip trajectories.

    Parameters
    ----------
    solver : IKSolver
        The solver of the M markers' (3M,) targets.
    offsets : array_like
        Each marker's offset from the tip (M, 3), m.
    """

    def __init__(self, solver, offsets):
        self.solver = solver
        self.offsets = np.asarray(offsets, float).reshape(-1, 3)

    def __getattr__(self, name):
        return getattr(self.solver, name)

    def expand(self, targets_W) -> np.ndarray:
        """The markers' targets of tip targets.

        Parameters
        ----------
        targets_W : array_like
            Tip targets (N, 3), m, frame W.

        Returns
        -------
        numpy.ndarray
            Targets (N, 3M), m: each marker's offset added.
        """
        t = np.atleast_2d(check_targets(targets_W))
        return np.hstack([t + o for o in self.offsets])

    def follow(self, targets_W, u0=None):
        """IK for each tip target in order, driving every marker (:meth:`IKSolver.follow`).

        Parameters
        ----------
        targets_W : array_like
            Tip targets (N, 3), m, frame W.
        u0 : array_like, optional
            The first point's start (m,); default a cold start.

        Returns
        -------
        TrajectoryIK
            The plan; ``targets_W`` the tip targets, ``p_pred_W`` (N, 3) the first marker's
            prediction less its offset, ``info["markers"]`` and ``info["marker_offsets_m"]``.
        """
        t = np.atleast_2d(check_targets(targets_W))
        plan = self.solver.follow(self.expand(t), u0)
        plan.targets_W = t
        plan.p_pred_W = np.asarray(plan.p_pred_W, float)[:, :3] - self.offsets[0]
        plan.info["markers"] = list(self.solver.config.markers)
        plan.info["marker_offsets_m"] = self.offsets.tolist()
        return plan


def with_marker_offsets(solver, model=None, fem=None):
    """``solver`` itself when it drives the tip alone, else an :class:`OffsetSolver` of it.

    Parameters
    ----------
    solver : IKSolver
        The solver (``config.markers`` the markers it drives).
    model : object, optional
        The forward model of every marker the solver was made from; None for Soft IK.
    fem : ArmFEM, optional
        The FEM of Soft IK.

    Returns
    -------
    IKSolver or OffsetSolver
        The solver that follows tip trajectories.
    """
    markers = tuple(solver.config.markers)
    if markers == ("tip",):
        return solver
    if model is None:
        if fem is None:
            raise InputError("Soft IK of markers needs the FEM")
        model = FEMForwardMap(fem, markers=tuple(fem.marker_names))
    return OffsetSolver(solver, rest_offsets(model, markers, solver.commands.lo))
