"""Stages 7-8: inverse kinematics and trajectories.

:class:`IKSolver` (:mod:`.ik`) minimises ``1/2 |y(u) - y'|^2`` over the allowed commands
(:class:`CommandSet`, :mod:`.command_set`) through *any* forward map with a Jacobian: a
learned model, or the FEM itself (:class:`FEMForwardMap`, :mod:`.soft_ik`: Soft IK); a
model without one by a derivative-free search (:mod:`.dfo`). Its settings are one
:class:`IKConfig` (:mod:`.ik_config`). :mod:`.follow` follows a
trajectory (redundant arms regularised automatically); :mod:`.spread` penalises and flags
an ensemble's spread.
:mod:`.redundancy` holds motors fixed and measures motor paths; :mod:`.trajectories`
makes the paper's target paths and reads/writes trajectory CSVs; :mod:`.workspace_shapes` scales
them into another robot's reachable workspace. Nothing here imports
:mod:`lab.learn`.
"""

from lab.control.command_set import CommandSet
from lab.control.dfo import dfo_solve
from lab.control.follow import AUTO_WEIGHT_REL, SLACK_COLUMN_REL, follow_trajectory
from lab.control.ik import (
    ARMIJO,
    METHODS,
    IKConfig,
    IKResult,
    IKSolver,
    TrajectoryIK,
    check_forward,
    check_targets,
    command_set,
    grid_seeds,
)
from lab.control.ik_step import projected_gradient_step
from lab.control.redundancy import FrozenMotors, frozen_commands, motor_path_stats
from lab.control.soft_ik import FEMForwardMap
from lab.control.spread import DEFAULT_MAX_SPREAD_M, has_spread, predicted_spread_m, spread_rows
from lab.control.trajectories import (
    BUILTIN,
    CENTRE_W,
    DEFAULT_POINTS,
    MAX_ABS_COORD_M,
    SIX_CABLE,
    SIX_CABLE_AXIS_W,
    builtin,
    circle,
    helix,
    load_trajectory,
    rose,
    saddle,
    square,
)
from lab.control.workspace_shapes import fitted_shape, workspace_plane

__all__ = [
    "CommandSet",
    "IKConfig",
    "METHODS",
    "ARMIJO",
    "IKResult",
    "TrajectoryIK",
    "check_targets",
    "check_forward",
    "command_set",
    "grid_seeds",
    "IKSolver",
    "projected_gradient_step",
    "follow_trajectory",
    "AUTO_WEIGHT_REL",
    "SLACK_COLUMN_REL",
    "dfo_solve",
    "DEFAULT_MAX_SPREAD_M",
    "has_spread",
    "predicted_spread_m",
    "spread_rows",
    "FEMForwardMap",
    "FrozenMotors",
    "frozen_commands",
    "motor_path_stats",
    "CENTRE_W",
    "fitted_shape",
    "workspace_plane",
    "BUILTIN",
    "SIX_CABLE",
    "SIX_CABLE_AXIS_W",
    "DEFAULT_POINTS",
    "MAX_ABS_COORD_M",
    "circle",
    "square",
    "rose",
    "helix",
    "saddle",
    "builtin",
    "load_trajectory",
]
