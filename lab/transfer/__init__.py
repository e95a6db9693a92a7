"""Closing the sim-to-real gap with the physics: calibrate the FEM to a few real samples.

:func:`calibrate` (:mod:`.calibrate`) identifies the as-built parameters of the FEM
(softness, stiffness gradient, eyelet shifts, slack per cable; :mod:`lab.fem.solve.parameters`)
from N real (u, y) samples by Levenberg-Marquardt with exact parameter sensitivities and a
prior towards the nominal description; :func:`calibrated_robot` /
:func:`write_calibrated_robot` (:mod:`.robot_toml`) turn the result into a robot
description TOML that every command accepts as ``--robot``. :func:`calibrated_model`
(:mod:`.calibrated`) is the ``calibrated`` transfer method (calibrate, re-simulate, train);
:mod:`.recovery` compares recovered with true parameters on emulated as-built robots.
The ``transfer`` and ``calibrate`` commands' runs, with their typed settings, are
:mod:`.transfer_run` and :mod:`.calibration_run`.
"""

from lab.transfer.calibrate import (
    DEFAULT_PRIOR_STD,
    DISCREPANCY_QUANTILE,
    CalibrationResult,
    calibrate,
    model_check,
    prior_std,
)
from lab.transfer.calibrated import calibrated_model
from lab.transfer.calibration_run import CalibrationSpec, calibration_run, calibration_summary
from lab.transfer.recovery import family_recovery, recovery_rows, recovery_summary, true_theta
from lab.transfer.robot_toml import calibrated_robot, calibrated_toml, robot_toml, write_calibrated_robot
from lab.transfer.transfer_run import TRANSFER_METHODS, TransferSpec, fit_mean_distance_mm, transfer_run

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
    "CalibrationSpec",
    "calibration_run",
    "calibration_summary",
    "TRANSFER_METHODS",
    "TransferSpec",
    "transfer_run",
    "fit_mean_distance_mm",
    "true_theta",
    "recovery_rows",
    "family_recovery",
    "recovery_summary",
]
