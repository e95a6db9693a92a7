"""Closing the sim-to-real gap with the physics: calibrate the FEM to a few real samples.

:func:`calibrate` (``lab/transfer/calibrate.py``) identifies the as-built parameters of the FEM
(softness, stiffness gradient, eyelet shifts, slack per cable; :mod:`lab.fem.solve.parameters`)
from N real (u, y) samples by Levenberg-Marquardt with exact parameter sensitivities and a
prior towards the nominal description, and :func:`model_check` (:mod:`.discrepancy`) tests
whether the fit explains the samples; :func:`calibrated_robot` /
:func:`write_calibrated_robot` (:mod:`.robot_toml`) turn the result into a robot
description TOML that every command accepts as ``--robot``. :func:`calibrated_model`
(:mod:`.calibrated`) is the ``calibrated`` transfer method (calibrate, re-simulate, train).
The transfer methods that need only data (real-only, fine-tuning, the GP residual) are
behind one call, :func:`transfer_model` (:mod:`.data_methods`); :mod:`.recovery` compares
recovered with true parameters on emulated as-built robots. The ``transfer`` and
``calibrate`` commands' runs, with their typed settings, are :mod:`lab.jobs.transfer` and
:mod:`lab.jobs.calibrate`.
"""

from lab.transfer.calibrate import (
    DEFAULT_PRIOR_STD,
    CalibrationResult,
    calibrate,
    prior_std,
)
from lab.transfer.calibrated import calibrated_model
from lab.transfer.data_methods import DATA_METHODS, transfer_model
from lab.transfer.discrepancy import DISCREPANCY_QUANTILE, model_check
from lab.transfer.recovery import family_recovery, recovery_rows, recovery_summary, true_theta
from lab.transfer.robot_toml import calibrated_robot, calibrated_toml, robot_toml, write_calibrated_robot

__all__ = [
    "DEFAULT_PRIOR_STD",
    "CalibrationResult",
    "DISCREPANCY_QUANTILE",
    "calibrate",
    "model_check",
    "prior_std",
    "calibrated_robot",
    "calibrated_toml",
    "robot_toml",
    "write_calibrated_robot",
    "calibrated_model",
    "DATA_METHODS",
    "transfer_model",
    "true_theta",
    "recovery_rows",
    "family_recovery",
    "recovery_summary",
]
