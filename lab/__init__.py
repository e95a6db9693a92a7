"""lab: soft robot control with a learned differentiable model.

The package follows the paper's pipeline, one subpackage per stage, each importing only
the stages before it. A robot **description** (:mod:`lab.description`, TOML files in
``lab/robots/``) is meshed and given a neo-Hookean **energy** with one-sided cables,
whose **static solve** and sensitivities ``dx/du`` are in :mod:`lab.fem`. Sampling motor
commands and solving them gives (u, y) **data** (:mod:`lab.data`), from which
:mod:`lab.learn` trains the **model** -- a small MLP with the Appendix's analytic
Jacobian. :mod:`lab.control` inverts any such forward map (**IK**) and makes target
**trajectories**; :mod:`lab.rig` drives the **rig** -- the FEM, an emulated as-built
twin or the real Dynamixel/OptiTrack hardware -- and captures data on it;
:mod:`lab.tracking` follows trajectories on a rig and tabulates Table I. :mod:`lab.viz`
draws, :mod:`lab.cli` is the command line (``python -m lab`` or ``lab``). Every error
raised on purpose derives from :class:`lab.errors.LabError`; shared file helpers
(atomic writes, JSON) are in :mod:`lab.files`.
"""

__version__ = "0.1.0"
