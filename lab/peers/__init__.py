"""Peers: the arm in the simulators and solvers users would pick instead of ours (issue 17).

:func:`mujoco_arm` builds the cable-driven arm as a MuJoCo model on our tet mesh (a 3D flex
with spatial tendons as the cables; :mod:`.mujoco_arm`), so ``benchmarks/bench_peers.py`` can
compare its settled states, times and Jacobians with our static FEM. ``mujoco`` is imported
when a model is built, not when this package is.
"""

from lab.peers.mujoco_arm import MujocoArm, SettleResult, mujoco_arm

__all__ = ["MujocoArm", "SettleResult", "mujoco_arm"]
