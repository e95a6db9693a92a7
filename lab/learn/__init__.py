"""Stage 6: the learned forward model u -> y.

:class:`MLP` (:mod:`.mlp`, initialised by :mod:`.mlp_init`) with the Appendix's analytic Jacobian, stored by
:mod:`.model_io` (``.npz`` + JSON, no pickle); training by MATLAB-faithful
Levenberg-Marquardt (:mod:`.lm`, its products from the layers' structure in
:mod:`.gauss_newton`), its sub-sampled form for large datasets (:mod:`.lm_subsample`; which
one by size: :mod:`.algorithm_choice`), Bayesian regularisation (:mod:`.bayes`) or Adam /
L-BFGS (:mod:`.gradient`) behind one entry
point :func:`train` (``lab/learn/train.py``) on ``dividerand`` splits (:mod:`.split`); every trainer
takes one :class:`TrainingData` (:mod:`.training_data`) and its algorithm's options; error
metrics (:mod:`.metrics`) and the repeated-split and network-size studies (:mod:`.studies`).
A run's settings are one :class:`TrainSpec` (:mod:`.train_spec`; memory check in
:mod:`.network_size`); what ``train`` and ``splits`` (:mod:`lab.jobs`) fit on comes from
dataset files by :mod:`.run_inputs`. History models of measured sequences and their
past-fixed views: :mod:`.history`. Sim-to-real transfer from a few real samples:
fine-tuning (:mod:`.finetune`) and the GP residual model (:mod:`.residual`), behind one
call in :mod:`lab.transfer.data_methods`. Active sampling (:mod:`.active`), run from a
design's settings by :mod:`.active_design`. How well a model's spread explains held-out errors:
:mod:`.spread_calibration`.
The foam in time (the relaxation filter and its fits) is :mod:`lab.dynamics`.
"""

from lab.learn.active import ActiveSpec, active_sampling, pick_apart
from lab.learn.active_design import active_settings, check_active, run_active
from lab.learn.bayes import BROptions, train_br
from lab.learn.ensemble import Ensemble, load_ensemble, train_ensemble
from lab.learn.finetune import finetune, finetune_fixed
from lab.learn.gradient import AdamOptions, LBFGSOptions, train_adam, train_lbfgs
from lab.learn.history import MAX_HISTORY, at_rest, data_bounds, history_features, history_of, with_past
from lab.learn.inverse import InverseModel, fit_inverse, inverse_tip_errors, load_inverse
from lab.learn.lm import STOP_MESSAGES, LMOptions, TrainLog, lm_step, mse, stop_message, train_lm
from lab.learn.lm_subsample import LMSubsampleOptions, train_lm_subsample
from lab.learn.metrics import error_report, mean_distance_m, mse_m2, workspace_size_m
from lab.learn.mlp import MLP, minmax_gain
from lab.learn.mlp_init import init_mlp
from lab.learn.model_io import ModelFileError, file_metadata, model_arrays, read_model, save_model
from lab.learn.model_specs import (
    EnsembleSpec,
    GPRSpec,
    InverseSpec,
    KNNSpec,
    NetworkSpec,
    SklearnMLPSpec,
    model_spec,
)
from lab.learn.models import MODEL_CHOICES, evaluate_model_splits, fit_model, load_model
from lab.learn.network_size import check_network_size
from lab.learn.peers import GPRModel, KNNModel, SklearnMLPModel, fit_gpr, fit_knn, fit_sklearn_mlp, load_peer
from lab.learn.residual import GPCorrection, ResidualModel, fit_residual, load_residual
from lab.learn.split import Split, check_enough_data, minimum_samples
from lab.learn.spread_calibration import calibration
from lab.learn.studies import (
    evaluate_splits,
    run_seeds,
    size_sweep,
    summarize,
    write_csv,
)
from lab.learn.train import EpochProgress, TrainResult, data_sha256, max_epochs, train
from lab.learn.train_spec import TrainSpec
from lab.learn.training_data import TrainingData

__all__ = [
    "BROptions",
    "train_br",
    "Ensemble",
    "calibration",
    "load_ensemble",
    "train_ensemble",
    "MODEL_CHOICES",
    "evaluate_model_splits",
    "fit_model",
    "model_spec",
    "NetworkSpec",
    "EnsembleSpec",
    "InverseSpec",
    "GPRSpec",
    "KNNSpec",
    "SklearnMLPSpec",
    "ActiveSpec",
    "active_sampling",
    "run_active",
    "active_settings",
    "check_active",
    "pick_apart",
    "MAX_HISTORY",
    "at_rest",
    "data_bounds",
    "history_features",
    "history_of",
    "with_past",
    "InverseModel",
    "fit_inverse",
    "inverse_tip_errors",
    "load_inverse",
    "GPRModel",
    "KNNModel",
    "SklearnMLPModel",
    "fit_gpr",
    "fit_knn",
    "fit_sklearn_mlp",
    "load_peer",
    "finetune",
    "finetune_fixed",
    "file_metadata",
    "model_arrays",
    "GPCorrection",
    "ResidualModel",
    "fit_residual",
    "load_residual",
    "STOP_MESSAGES",
    "stop_message",
    "minmax_gain",
    "MLP",
    "init_mlp",
    "load_model",
    "ModelFileError",
    "save_model",
    "read_model",
    "Split",
    "check_enough_data",
    "minimum_samples",
    "mse",
    "LMOptions",
    "TrainLog",
    "train_lm",
    "lm_step",
    "LMSubsampleOptions",
    "train_lm_subsample",
    "AdamOptions",
    "LBFGSOptions",
    "TrainingData",
    "train_adam",
    "train_lbfgs",
    "data_sha256",
    "TrainResult",
    "train",
    "EpochProgress",
    "max_epochs",
    "TrainSpec",
    "check_network_size",
    "mse_m2",
    "mean_distance_m",
    "error_report",
    "workspace_size_m",
    "run_seeds",
    "evaluate_splits",
    "size_sweep",
    "summarize",
    "write_csv",
]
