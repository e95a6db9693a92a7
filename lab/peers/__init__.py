"""Peers: the arm in the simulators and solvers users would pick instead of ours.

:func:`mujoco_arm` builds the cable-driven arm as a MuJoCo model on our tet mesh (a 3D flex
with spatial tendons as the cables; :mod:`.mujoco_arm`), so ``benchmarks/bench_peers.py`` can
compare its settled states, times and Jacobians with our static FEM. ``mujoco`` is imported
when a model is built, not when this package is.

:class:`SkfemArm` is the arm's body (no cables) in scikit-fem with our neo-Hookean law on the
same mesh (:mod:`.skfem_arm`): gravity sag, a tip load and the adjoint gradient of the tip with
respect to that load, against ours. ``skfem`` too is imported when an arm is built.
"""

from lab.peers.mujoco_arm import MujocoArm, SettleResult, mujoco_arm
from lab.peers.skfem_arm import SkfemArm, lab_loaded_arm, lab_tip_load_gradient

__all__ = [
    "MujocoArm",
    "SettleResult",
    "SkfemArm",
    "lab_loaded_arm",
    "lab_tip_load_gradient",
    "mujoco_arm",
]
