"""The ``calibrated`` transfer method: calibrate the FEM, re-simulate, retrain.

From N real samples, :func:`lab.transfer.calibrate` identifies the as-built parameters
theta (:func:`lab.transfer.prior.default_groups`: softness, stiffness gradient, eyelet
shifts and, with an angle-controlled cable, slack per cable) on every marker the data
holds; the calibrated description then simulates the same commands as the simulated
dataset (e.g. the 308 lattice points), and a fresh network is trained on those markers
(the data's, in its column order: the tip alone for a tip-only dataset, as always). Unlike the data-only
methods, the real samples never enter the network directly: they only move the physics.
What the static FEM cannot represent (lag, hysteresis, play, friction) stays as bias.

Calibration and re-simulation use one mesh (``n_rings``/``n_axial``): a coarse mesh's own
discretisation error is then absorbed by the identified softness, which makes a coarse
mesh (2 x 10) a good and fast choice.
"""

from __future__ import annotations

import numpy as np

from lab.description import RobotDescription
from lab.errors import InputError, LabRuntimeError
from lab.transfer.calibrate import calibrate
from lab.transfer.robot_toml import calibrated_robot, calibrated_toml

__all__ = ["MIN_RESIMULATED", "calibrated_model"]

#: The fewest commands the calibrated FEM re-simulates for the network trained on them.
MIN_RESIMULATED = 10


def calibrated_model(
    robot: RobotDescription,
    u_real,
    y_real,
    u_sim,
    *,
    hidden=(20, 20),
    seed: int = 0,
    n_rings: int | None = None,
    n_axial: int | None = None,
    n_jobs: int = 1,
    max_iter: int = 30,
    log=None,
    markers=None,
):
    """A network for the real arm by calibrated physics.

    ``u_real`` (N, m) and ``y_real`` (N, 3K) m: the real samples; ``u_sim`` (S, m):
    the commands re-simulated on the calibrated FEM (those of the simulated dataset).
    Mesh of calibration and re-simulation: ``n_rings``/``n_axial`` (default: the
    description's). Returns the trained MLP; its ``metadata["transfer"]`` holds the
    calibration summary (values, std, fit) and the calibrated description as TOML text, so
    the model file says which physics it was trained on.

    Parameters
    ----------
    robot : RobotDescription
        The nominal description that is calibrated.
    u_real : array_like
        Real inputs, shape (N, m), each in its unit (rad, N).
    y_real : array_like
        Real marker positions, shape (N, 3K), m, frame W: (x, y, z) of each of ``markers``.
    u_sim : array_like
        Commands re-simulated on the calibrated FEM, shape (S, m), in the inputs' units (S >= 10).
    hidden : tuple of int
        Hidden layer sizes of the network.
    seed : int
        Seed of the split and the initial weights.
    n_rings, n_axial : int, optional
        Mesh of calibration and re-simulation (default: the description's).
    n_jobs : int
        Worker processes of the re-simulation.
    max_iter : int
        Most Levenberg-Marquardt iterations of the calibration.
    log : callable, optional
        Called with a progress line (str).
    markers : sequence of str, optional
        The markers the columns of ``y_real`` hold, in order (names of
        ``robot.marker_names``); default the tip alone.

    Returns
    -------
    MLP
        The trained network u -> the markers (m, frame W; the tip alone for a tip-only
        dataset), with the calibration in its ``metadata["transfer"]``.

    Raises
    ------
    InputError
        For bad data.
    LabRuntimeError
        When the calibrated FEM has no equilibrium for more than a tenth of ``u_sim``.
    """
    from lab.data.chunks import nearest_neighbour_chunks
    from lab.data.simulation import simulate
    from lab.learn.train import train

    u_sim = np.asarray(u_sim, float)
    if u_sim.ndim != 2 or u_sim.shape[1] != robot.n_inputs or len(u_sim) < MIN_RESIMULATED:
        raise InputError(
            f"expected at least {MIN_RESIMULATED} commands to re-simulate, (S, {robot.n_inputs}) rad; got {u_sim.shape}"
        )
    markers = ("tip",) if markers is None else tuple(markers)
    # the groups: calibrate's default, lab.transfer.prior.default_groups (slack only with an angle cable)
    result = calibrate(
        robot, u_real, y_real, n_rings=n_rings, n_axial=n_axial, max_iter=max_iter, log=log, markers=markers
    )
    cal = calibrated_robot(robot, result)
    sim = simulate(
        cal,
        u_sim,
        nearest_neighbour_chunks(u_sim),
        n_rings=result.n_rings,
        n_axial=result.n_axial,
        n_jobs=n_jobs,
    )
    ok = np.all(np.isfinite(sim["p_tip_W"]), axis=1)
    if ok.sum() < 0.9 * len(u_sim):
        raise LabRuntimeError(
            f"the calibrated FEM found no equilibrium for {len(u_sim) - ok.sum()} of {len(u_sim)} commands"
        )
    model = train(u_sim[ok], _resimulated(sim, robot, markers)[ok], tuple(hidden), seed=seed).model
    model.metadata["transfer"] = {
        "method": "calibrated",
        "n_real": int(len(np.asarray(u_real))),
        "seed": seed,
        "n_resimulated": int(ok.sum()),
        "resimulate_wall_s": float(sim["wall_s"]),
        "calibration": result.summary(),
        "calibrated_robot_toml": calibrated_toml(robot, result),
    }
    if markers != ("tip",):
        model.metadata["transfer"]["markers"] = list(markers)
    return model


def _resimulated(sim: dict, robot: RobotDescription, markers: tuple) -> np.ndarray:
    """The re-simulated outputs of ``markers`` (S, 3K) m: the tips for a tip-only dataset,
    else those markers' columns of the simulation's ``y_W`` (every marker of the robot)."""
    if markers == ("tip",):
        return sim["p_tip_W"]
    y_all = sim.get("y_W")
    if y_all is None:
        raise LabRuntimeError("the re-simulation returned the tip alone; markers need its y_W (every marker)")
    y_all = np.asarray(y_all).reshape(len(sim["p_tip_W"]), -1, 3)
    return y_all[:, [robot.marker_names.index(k) for k in markers]].reshape(len(y_all), -1)
