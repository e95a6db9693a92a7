"""An ``--active N --batch B`` design, run: the loop that ``simulate`` and ``capture`` share.

:func:`run_active` runs :func:`lab.learn.active.active_sampling` with the settings of a
:class:`lab.data.DesignSpec` and one line per measured batch (:func:`print_batch`); what
measures a batch -- the FEM or a rig -- and what keeps it (a checkpoint, a journal) are
callables of the caller. :func:`active_settings` is what a run records and what a resumed
run must share; :func:`check_active` refuses, before anything is measured, a budget whose
initial design is too small to fit the first ensemble to.
"""

from __future__ import annotations

import functools
import sys

from lab.data.design_spec import ACTIVE_POOL, DesignSpec
from lab.description import RobotDescription
from lab.errors import InputError
from lab.learn.active import ActiveSpec, active_sampling, default_initial, default_radius
from lab.learn.ensemble import member_ratios, train_ensemble
from lab.learn.split import minimum_samples

__all__ = ["active_settings", "check_active", "print_batch", "run_active", "DENSITY_RADIUS"]

#: Radius (in ``u / u_max``) of the pool density that weighs the ensemble's spread.
DENSITY_RADIUS = 0.3


def _active(design: DesignSpec) -> DesignSpec:
    if design.kind != "active":
        raise InputError(f"not an active design: {' '.join(design.words())}")
    return design


def active_settings(design: DesignSpec, robot: RobotDescription) -> dict:
    """The settings of ``design`` (JSON-able): the sampler's metadata, and what a resumed
    run (checkpoint or journal) must share.

    Parameters
    ----------
    design : DesignSpec
        A design with an active-sampling budget.
    robot : RobotDescription
        The robot sampled (its motors set the sampler's radius).

    Returns
    -------
    dict
        ``n``, ``batch``, ``seed``, ``n_initial``, ``pool_size``, ``radius`` (rad),
        ``ensemble`` settings and the rest of the sampler's metadata.
    """
    d = _active(design)
    return {
        "name": "active",
        "n": d.active,
        "batch": d.batch,
        "seed": d.seed,
        "initial_design": "sobol",
        "n_initial": default_initial(d.active),
        "pool_size": ACTIVE_POOL,
        "radius": default_radius(d.active, robot.n_inputs),
        "density_radius": DENSITY_RADIUS,
        "ensemble": {
            "trainer": "lab.learn.ensemble.train_ensemble",
            "members": d.ensemble_members,
            "hidden": list(d.ensemble_hidden),
            "epochs": d.ensemble_epochs,
        },
    }


def check_active(design: DesignSpec, robot: RobotDescription) -> None:
    """Refuse (InputError) an ``--active`` budget whose initial Sobol design (half of it)
    has fewer samples than the first ensemble needs to train on (:func:`minimum_samples`
    of each member's split), unless that design is the whole budget.

    Parameters
    ----------
    design : DesignSpec
        A design with an active-sampling budget.
    robot : RobotDescription
        The robot sampled.
    """
    d = _active(design)
    n_initial = default_initial(d.active)
    need = minimum_samples(robot.n_inputs, member_ratios())
    if n_initial < d.active and n_initial < need:
        active = d.name_of("active")
        raise d.field_error(
            f"{active} {d.active} starts from a Sobol design of {n_initial} samples, too few to train the first "
            f"ensemble on ({robot.name}: at least {need}); use {active} {2 * need} or more",
            "active",
        )


def print_batch(entry: dict, n_total: int, file) -> None:
    """One line per measured batch (a log ``entry`` of :func:`active_sampling`) on ``file``."""
    done = entry["n_before"] + entry["n"]
    if entry["kind"] == "initial":
        print(f"batch 0: initial {entry['design']} design, {entry['n']} commands ({done}/{n_total})", file=file)
        return
    print(
        f"batch {entry['batch']}: {entry['n']} commands ({done}/{n_total}); ensemble spread in the pool "
        f"mean {1e3 * entry['pool_spread_mean_m']:.3f} mm max {1e3 * entry['pool_spread_max_m']:.3f} mm, "
        f"of the picks mean {1e3 * entry['picked_spread_mean_m']:.3f} mm (fit {entry['fit_s']:.1f} s)",
        file=file,
    )


def run_active(
    design: DesignSpec,
    robot: RobotDescription,
    measure_batch,
    *,
    u_done=None,
    y_done=None,
    n_jobs: int = 1,
    on_pick=None,
    on_batch=None,
    file=None,
):
    """Measure ``design.active`` safe commands of ``robot``, batch by batch, where the
    ensemble of ``design`` disagrees most (:func:`lab.learn.active.active_sampling` with
    the :class:`lab.learn.active.ActiveSpec` of ``design``'s settings).

    Parameters
    ----------
    design : DesignSpec
        The design's settings: ``active``, ``batch``, the ensemble's and the sampler's.
    robot : RobotDescription
        The robot measured.
    measure_batch : callable
        ``measure_batch(u (B, m) rad) -> y (B, 3) m`` measures a batch.
    u_done, y_done : array_like, shape (N, m) rad and (N, 3) m, optional
        Samples of an earlier run of the same settings to continue after.
    n_jobs : int
        Worker processes training the ensemble's members (the result does not depend on it).
    on_pick : callable, optional
        ``on_pick(u, entry)``, called before a batch is measured (e.g. to journal the plan).
    on_batch : callable, optional
        ``on_batch(u, y, entry)``, called after (e.g. to save it); then the batch's line
        is printed on ``file``.
    file : file-like, optional
        Where the batch lines go (default stderr).

    Returns
    -------
    u : numpy.ndarray, shape (n, m)
        Commands (rad).
    y : numpy.ndarray, shape (n, 3)
        Tips (m).
    log : list of dict
        This call's batches, as :func:`lab.learn.active.active_sampling`'s.
    """
    check_active(design, robot)
    settings = active_settings(design, robot)

    def batch_done(u_b, y_b, entry):
        if on_batch is not None:
            on_batch(u_b, y_b, entry)
        print_batch(entry, design.active, sys.stderr if file is None else file)

    spec = ActiveSpec(
        n_total=design.active,
        batch=design.batch,
        n_initial=settings["n_initial"],
        pool_size=settings["pool_size"],
        radius=settings["radius"],
        density_radius=settings["density_radius"],
        hidden=tuple(design.ensemble_hidden),
        k=design.ensemble_members,
        seed=design.seed,
        epochs=design.ensemble_epochs,
    )
    return active_sampling(
        robot,
        measure_batch,
        spec,
        u_done=u_done,
        y_done=y_done,
        fit_ensemble=functools.partial(train_ensemble, n_jobs=n_jobs),
        on_pick=on_pick,
        on_batch=batch_done,
    )
