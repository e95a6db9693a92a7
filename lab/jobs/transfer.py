"""``python -m lab transfer``: a forward model for the real arm from simulation and N real samples.

:class:`TransferSpec` says which method (``method``: the data-only methods of
:mod:`lab.transfer.data_methods`, or ``calibrated``, :mod:`lab.transfer.calibrated`), which
files (``real``, ``sim`` or ``sim_model``, ``robot``), the network
(:class:`lab.learn.TrainSpec`'s ``--hidden`` and ``--seed``), the mesh of the calibrated
method (:class:`lab.fem.MeshSpec`) and its workers, and refuses combinations that do not
go together. :func:`run` reads the datasets, checks them against the robot and
builds the model; the real samples may come from any rig, hardware included.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from lab.errors import FieldError, InputError
from lab.fem.bodies.mesh_spec import MeshSpec, mesh_label
from lab.learn.train_spec import TrainSpec
from lab.specs import Spec, option, positive_int
from lab.transfer.data_methods import DATA_METHODS

__all__ = ["TRANSFER_METHODS", "TransferSpec", "run", "fit_mean_distance_mm"]

TRANSFER_METHODS = (*DATA_METHODS, "calibrated")


@dataclass(frozen=True)
class TransferSpec(Spec):
    """One transfer: method, input files, network (``train``) and calibration mesh (``mesh``).

    Parameters
    ----------
    method : str
        One of :data:`TRANSFER_METHODS`.
    sim : str, optional
        Simulated dataset CSV: a network is trained on it (``calibrated``: its commands are re-simulated).
    sim_model : str, optional
        Instead of ``sim``: a network already trained on simulation (.npz).
    real : str
        Real dataset CSV (from ``capture``).
    robot : str, optional
        Robot name or description TOML; checked against the datasets' robots.
    jobs : int
        ``calibrated``: worker processes of the re-simulation.
    train : TrainSpec
        The network (its ``hidden`` widths and ``seed``).
    mesh : MeshSpec
        ``calibrated``: the mesh of calibration and re-simulation.
    """

    method: str = option(None, required=True, choices=TRANSFER_METHODS, help="transfer method")
    sim: str | None = option(
        None, help="simulated dataset CSV (e.g. data/sim_three_cable.csv): a network is trained on it"
    )
    sim_model: str | None = option(None, help="instead of --sim: a network already trained on simulation (.npz)")
    real: str = option(None, required=True, help="real dataset CSV (from `capture`)")
    robot: str | None = option(None, help="robot name or description TOML; checked against the datasets' robots")
    jobs: int = option(1, type=int, check=positive_int, help="calibrated: worker processes of the re-simulation")
    train: TrainSpec = field(default_factory=TrainSpec)
    mesh: MeshSpec = field(default_factory=MeshSpec)

    def __post_init__(self):
        super().__post_init__()
        if self.method == "calibrated" and (self.sim is None or self.sim_model is not None or self.robot is None):
            raise FieldError(
                "TransferSpec.method calibrated needs TransferSpec.robot R and TransferSpec.sim SIM.csv (its "
                "commands are re-simulated), not TransferSpec.sim_model"
            )
        if self.method != "calibrated" and not self.mesh.is_default:
            raise FieldError("MeshSpec.n_rings/MeshSpec.n_axial are options of TransferSpec.method calibrated only")
        if self.method not in ("real-only", "calibrated") and (self.sim is None) == (self.sim_model is None):
            raise FieldError(
                f"TransferSpec.method {self.method} needs exactly one of TransferSpec.sim SIM.csv and "
                "TransferSpec.sim_model SIM.npz"
            )


def _check_robot(robot, meta: dict, what: str, n_u: int) -> None:
    """Refuse a dataset (``what``: its field and path) made on another robot than ``TransferSpec.robot``
    or whose ``n_u`` motor columns are not the robot's motors."""
    name = (meta.get("robot") or {}).get("name")
    if robot is not None and name is not None and name != robot.name:
        raise FieldError(f"{what} was made on robot {name!r}, but TransferSpec.robot is {robot.name!r}")
    if robot is not None and n_u != robot.n_inputs:
        raise FieldError(
            f"{what} has {n_u} motor columns (u0..u{n_u - 1}), but TransferSpec.robot {robot.name} has "
            f"{robot.n_inputs} motors"
        )


def _read(path, what: str, robot):
    """The dataset ``path`` of flag ``what``: (u (N, n_u), y (N, 3K) m, metadata), not empty,
    with its markers (:func:`lab.data.dataset.dataset_markers`) and input units fitting the robot."""
    from lab.data.dataset import read_dataset

    u, y, meta = read_dataset(path)
    if len(u) == 0:
        raise FieldError(f"{what} {path} holds no samples")
    _check_robot(robot, meta, f"{what} {path}", u.shape[1])
    _markers(robot, meta, y, f"{what} {path}")
    units = meta.get("input_units")
    if robot is not None and units is not None and tuple(units) != tuple(robot.input_units):
        raise FieldError(
            f"{what} {path} has inputs in {', '.join(map(str, units))}, but TransferSpec.robot {robot.name}'s "
            f"are in {', '.join(robot.input_units)}"
        )
    return u, y, meta


def _markers(robot, meta: dict, y, what: str = "TransferSpec.real") -> tuple[str, ...]:
    """:func:`lab.data.dataset.dataset_markers`, its error naming the setting."""
    from lab.data.dataset import DatasetError, dataset_markers

    try:
        return dataset_markers(meta, y, robot, what)
    except DatasetError as err:
        raise FieldError(str(err)) from None


def run(spec: TransferSpec, *, command: str = "", log=None):
    """The model ``spec`` asks for, its ``metadata["transfer"]`` recording the files and ``command``.

    Parameters
    ----------
    spec : TransferSpec
        The method, files, network and mesh.
    command : str
        The command line, recorded in the model's metadata.
    log : callable, optional
        Called with each progress line.

    Returns
    -------
    model : object
        The forward model (an MLP or a residual model), ready to save.
    real : tuple of ndarray
        The real data: u (N, n_u) and y (N, 3K) m. InputError for files or data that do
        not fit the method or the robot.
    """
    from lab.description import load_robot

    log = log or (lambda line: None)
    robot = load_robot(spec.robot) if spec.robot else None
    u_real, y_real, real_meta = _read(spec.real, "TransferSpec.real", robot)
    markers = _markers(robot, real_meta, y_real)
    if spec.method == "calibrated":
        model = _calibrated(spec, robot, u_real, y_real, markers, log)
        model.metadata["transfer"].update({"real": str(spec.real), "sim": spec.sim, "command": command})
        return model, (u_real, y_real)
    from lab.learn.mlp import load_model
    from lab.learn.train import train
    from lab.transfer.data_methods import transfer_model

    hidden, seed, sim_model = spec.train.hidden, spec.train.seed, None
    if spec.method != "real-only":
        if spec.sim_model:
            sim_model = load_model(spec.sim_model)
            if robot is not None and sim_model.n_u != robot.n_inputs:
                raise FieldError(
                    f"TransferSpec.sim_model {spec.sim_model} takes {sim_model.n_u} motor angles, but "
                    f"TransferSpec.robot {robot.name} "
                    f"has {robot.n_inputs} motors"
                )
        else:
            u_sim, y_sim, sim_meta = _read(spec.sim, "TransferSpec.sim", robot)
            if u_sim.shape[1] != u_real.shape[1]:
                raise FieldError(
                    f"TransferSpec.sim {spec.sim} has {u_sim.shape[1]} motor columns, but TransferSpec.real "
                    f"{spec.real} has "
                    f"{u_real.shape[1]}: they are not of one robot"
                )
            sim_markers = _markers(robot, sim_meta, y_sim, f"TransferSpec.sim {spec.sim}")
            if sim_markers != markers:
                raise FieldError(
                    f"TransferSpec.sim {spec.sim} holds the markers {', '.join(sim_markers)}, but TransferSpec.real "
                    f"{spec.real} holds {', '.join(markers)}: simulate the same markers"
                )
            log(f"training {list(hidden)} on {len(u_sim)} simulated samples ({spec.sim})")
            sim_model = train(u_sim, y_sim, hidden, seed=seed).model
        if (sim_model.n_u, sim_model.n_y) != (u_real.shape[1], y_real.shape[1]):
            raise FieldError(
                f"the simulation network ({spec.sim_model or spec.sim}) maps {sim_model.n_u} -> {sim_model.n_y}, "
                f"the real data (TransferSpec.real {spec.real}) {u_real.shape[1]} -> {y_real.shape[1]}"
            )
    log(f"{spec.method}: {len(u_real)} real samples from {spec.real}")
    model = transfer_model(spec.method, u_real, y_real, sim_model, hidden=tuple(hidden), seed=seed)
    model.metadata["transfer"].update(
        {"real": str(spec.real), "sim": spec.sim, "sim_model": spec.sim_model, "command": command}
    )
    return model, (u_real, y_real)


def _calibrated(spec: TransferSpec, robot, u_real, y_real, markers, log):
    from lab.transfer.calibrated import MIN_RESIMULATED, calibrated_model

    n_rings, n_axial = spec.mesh.resolve(robot)
    u_sim, _, _ = _read(spec.sim, "TransferSpec.sim", robot)
    if len(u_sim) < MIN_RESIMULATED:
        raise FieldError(
            f"TransferSpec.sim {spec.sim} holds {len(u_sim)} commands; the calibrated FEM re-simulates at least "
            f"{MIN_RESIMULATED}"
        )
    spec.train.check_fits(robot.n_inputs, 3 * len(markers), len(u_sim))  # before the calibration and re-simulation
    log(
        f"calibrated: {len(u_real)} real samples from {spec.real}; mesh {mesh_label(robot, n_rings, n_axial)}; "
        f"then {len(u_sim)} commands of {spec.sim} re-simulated"
    )
    try:
        return calibrated_model(
            robot, u_real, y_real, u_sim, hidden=tuple(spec.train.hidden), seed=spec.train.seed,
            n_rings=n_rings, n_axial=n_axial, n_jobs=spec.jobs, log=log, markers=markers,
        )  # fmt: skip
    except InputError as err:  # the real samples: the commands of TransferSpec.sim were checked above
        raise FieldError(f"TransferSpec.real {spec.real}: {err}") from None


def fit_mean_distance_mm(model, u, y) -> float:
    """Mean distance between ``model``'s predictions and the markers.

    Parameters
    ----------
    model : object
        A forward model with ``predict(u)``.
    u : ndarray, shape (N, n_u)
        Commands, each in its unit.
    y : ndarray, shape (N, 3K)
        Markers (the tip first), m.

    Returns
    -------
    float
        Mean Euclidean distance over the samples and the K markers, mm.
    """
    y = np.asarray(y, dtype=float)
    if y.shape[1] == 3:  # the tip alone, as always
        return 1e3 * float(np.mean(np.linalg.norm(model.predict(u) - y, axis=1)))
    d = (np.asarray(model.predict(u)) - y).reshape(len(y), -1, 3)
    return 1e3 * float(np.mean(np.linalg.norm(d, axis=2)))
