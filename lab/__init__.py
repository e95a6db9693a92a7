"""lab: soft robot control with a learned differentiable model.

The package follows the paper's pipeline, one subpackage per stage, each importing only
the stages before it. A robot **description** (:mod:`lab.description`, TOML files in
``lab/robots/``) is meshed and given a neo-Hookean **energy** with one-sided cables,
whose **static solve** and sensitivities ``dx/du`` are in :mod:`lab.fem`. Sampling motor
commands and solving them gives (u, y) **data** (:mod:`lab.data`), from which
:mod:`lab.learn` trains the **model** -- a small MLP with the Appendix's analytic
Jacobian -- and :mod:`lab.dynamics` the foam's lag in time. :mod:`lab.control` inverts any
such forward map (**IK**) and makes **trajectories**; :mod:`lab.rig` drives the **rig** --
the FEM, an emulated as-built twin (the **as-built robots**: :mod:`lab.asbuilt`) or the
Dynamixel/OptiTrack hardware -- and :mod:`lab.capture` captures data on it;
:mod:`lab.transfer` calibrates the FEM to it; :mod:`lab.tracking` follows trajectories on
a rig; :mod:`lab.studies` tabulates Table I and the measured curves. :mod:`lab.viz` draws,
:mod:`lab.cli` is the command line (``python -m lab``). Errors raised on purpose derive
from :class:`lab.errors.LabError`; typed settings are in :mod:`lab.specs`.
"""

__version__ = "0.1.0"
