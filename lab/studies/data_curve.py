"""Error against the number of samples N, per sampling strategy (the data-efficiency study).

For one robot -- the nominal FEM (:class:`NominalBody`) or an emulated as-built robot
(:class:`lab.rig.twin.AsBuiltBody`) -- :func:`data_curve_row` draws N commands by one
sampling strategy (:data:`lab.studies.data_curve_plan.STRATEGIES`), measures the settled tips through the fast path
(:func:`lab.rig.twin.quasi_static_tips`, plus the robot's motion-capture noise), fits a
forward model and records ``model_error_m`` (mean distance in m on a common held-out set of
random allowed commands, noise-free), the Table I tracking error per shape and their mean
(m; :func:`lab.studies.transfer_study.evaluate_model`, optional), ``fit_s`` (s) and
``capture_h`` (N over the measured samples per hour). Each row depends only on (strategy,
N, seed) and the settings, so a study resumes row by row. Planning the rows and reading them
off: :mod:`lab.studies.data_curve_plan`. The design and its measurements:
``docs/design/studies.md``.
"""

from __future__ import annotations

import hashlib
import time
import zlib

import numpy as np

from lab.errors import InputError
from lab.rig.twin import quasi_static_tips
from lab.studies.transfer_study import SHAPES, evaluate_model, random_safe_commands

__all__ = ["NominalBody", "make_body", "heldout_set", "fit_forward_model", "draw_and_measure", "data_curve_row"]


class NominalBody:
    """The nominal FEM as a body with a quasi-static map (no lag, play or noise; warm-started solves).

    Parameters
    ----------
    robot : RobotDescription
        The robot.
    n_rings, n_axial : int, optional
        Override the description's mesh.
    """

    def __init__(self, robot, *, n_rings: int | None = None, n_axial: int | None = None):
        from lab.asbuilt.arm import EquilibriumCache
        from lab.fem.model import ArmFEM

        self.robot = robot
        self.fem = ArmFEM(robot, n_rings=n_rings, n_axial=n_axial)
        self.equilibria = EquilibriumCache(self.fem)

    def quasi_static_tip(self, u_motor) -> np.ndarray:
        """The equilibrium tip p_tip_W (3,) m (world frame) at ``u_motor`` (m,) rad.

        Parameters
        ----------
        u_motor : array_like, shape (m,)
            Motor command (rad).

        Returns
        -------
        numpy.ndarray, shape (3,)
            The settled tip (m).
        """
        u = np.asarray(u_motor, dtype=float)
        return self.equilibria.tip(self.robot.spool_radius_m * u)


def make_body(robot, rig: str, *, n_rings: int | None = None, n_axial: int | None = None):
    """The body a ``--rig`` spec measures through; ``hardware:`` rigs are refused (InputError).

    Parameters
    ----------
    robot : RobotDescription
        The nominal robot.
    rig : str
        ``sim`` or ``twin`` / ``twin:DEFECTS.toml`` / ``twin:random:SEED`` / ``twin:foam:SEED``.
    n_rings, n_axial : int, optional
        Override the description's mesh.

    Returns
    -------
    tuple
        ``(body, label, noise_sigma_m)``: ``sim``: a :class:`NominalBody`, "FEM", 0; ``twin...``: an
        as-built body, "emulated as-built robot", its motion-capture noise (m per axis).
    """
    from lab.fem.bodies.mesh_spec import MeshSpec
    from lab.rig import RigSpec, as_built_body

    spec = RigSpec.parse(rig)
    if spec.kind == "sim":
        return NominalBody(robot, n_rings=n_rings, n_axial=n_axial), spec.label, 0.0
    if spec.kind == "twin":
        body = as_built_body(spec, robot, mesh=MeshSpec(n_rings, n_axial))
        return body, spec.label, float(body.defects.noise_sigma_m)
    raise InputError(
        f"rig {rig!r}: the data curve measures through a body's quasi-static map; "
        "expected sim, twin, twin:DEFECTS.toml, twin:random:SEED or twin:foam:SEED"
    )


def heldout_set(body, n: int, seed: int) -> tuple[np.ndarray, np.ndarray, str]:
    """The common held-out set: ``n`` random allowed commands (seeded by ``seed``), noise-free.

    Parameters
    ----------
    body : NominalBody or AsBuiltBody
        The body whose settled tips are the truth.
    n, seed : int
        Number of commands (>= 1) and their seed.

    Returns
    -------
    tuple
        Commands (n, m) rad, their noise-free settled tips (n, 3) m, a short fingerprint (str).
    """
    if n < 1:
        raise InputError(f"the held-out set needs at least 1 command, got {n}")
    u = random_safe_commands(body.robot, n, seed)
    return u, quasi_static_tips(body, u), hashlib.sha256(np.ascontiguousarray(u).tobytes()).hexdigest()[:16]


def _row_rng(seed: int, strategy: str, n: int) -> np.random.Generator:
    """The noise stream of one row: a function of (seed, strategy, n) only."""
    return np.random.default_rng([int(seed), zlib.crc32(strategy.encode()), int(n)])


def fit_forward_model(
    name: str, u, y, *, hidden=(20, 20), seed: int = 0, epochs: int | None = None, algorithm: str = "lm"
):
    """A forward model fitted to u (N, m) rad -> y (N, 3) m.

    Parameters
    ----------
    name : str
        ``"mlp"`` by ``"lm"``: ``lab``'s network trained by LM with the paper's stopping
        rules on a 90/10 train/validation split (all for training below 10 samples), as the
        transfer curve's ``real-only``; anything else is fitted by
        :func:`lab.learn.models.fit_model` with :func:`lab.learn.model_specs.model_spec`
        of these settings (e.g. ``algorithm="br"``: Bayesian regularisation, no validation
        set; models ensemble, gpr, knn, sklearn-mlp).
    u : array_like, shape (N, m)
        Commands (rad).
    y : array_like, shape (N, 3)
        Tips (m).
    hidden : tuple of int
        Hidden widths of the networks.
    seed : int
        Seed of the fit.
    epochs : int, optional
        Maximum epochs of the networks (None: the trainer's default).
    algorithm : str
        The networks' training algorithm.

    Returns
    -------
    model
        The fitted forward model (``predict(u)`` -> y, m).
    """
    if name == "mlp" and algorithm == "lm":
        from lab.learn.train import train

        ratios = (0.9, 0.1, 0.0) if len(u) >= 10 else (1.0, 0.0, 0.0)
        return train(u, y, tuple(hidden), ratios=ratios, seed=seed, epochs=epochs).model
    try:
        from lab.learn.model_specs import model_spec
        from lab.learn.models import fit_model
    except ImportError:
        raise InputError(f"model {name!r} by {algorithm!r} needs lab.learn.models, which is missing") from None
    return fit_model(model_spec(name, hidden=tuple(hidden), seed=seed, epochs=epochs, algorithm=algorithm), u, y)


def draw_and_measure(body, strategy: str, n: int, levels, *, noise_sigma_m: float, seed: int, opts: dict):
    """Commands (n, m) rad of one row and their measured tips (n, 3) m (settled, plus noise of
    ``noise_sigma_m`` per axis from the row's own stream). ``active`` measures batch by batch
    as it samples (``opts``: ``batch``, ``n_initial`` (None: the sampler's default), ``hidden``,
    ``epochs``, ``algorithm`` of the ensemble)."""
    from lab.data.designs import design_commands, grid_commands

    rng = _row_rng(seed, strategy, n)

    def measure(u_batch):
        u_batch = np.atleast_2d(np.asarray(u_batch, float))
        tips = quasi_static_tips(body, u_batch)
        return tips + (rng.normal(0.0, noise_sigma_m, tips.shape) if noise_sigma_m > 0 else 0.0)

    robot = body.robot
    if strategy == "active":
        from lab.learn.active import ActiveSpec, active_sampling

        spec = ActiveSpec(
            n_total=n,
            batch=min(int(opts["batch"]), n),
            n_initial=None if opts.get("n_initial") is None else min(int(opts["n_initial"]), n),
            hidden=tuple(opts["hidden"]),
            seed=seed,
            epochs=opts["epochs"],
        )
        u, y, _ = active_sampling(robot, measure, spec, fit_ensemble=_ensemble_fitter(opts))
        return np.asarray(u, float), np.asarray(y, float)
    u = grid_commands(robot, levels) if strategy == "grid" else design_commands(robot, n, strategy, seed)
    return u, measure(u)


def _ensemble_fitter(opts: dict):
    """The active sampler's ensemble trained with the row's algorithm (None: its default)."""
    algorithm = opts.get("algorithm", "lm")
    if algorithm == "lm":
        return None
    from lab.learn.ensemble import train_ensemble

    return lambda u, y, **kw: train_ensemble(u, y, algorithm=algorithm, **kw)


def data_curve_row(
    body,
    strategy: str,
    n: int,
    levels=None,
    *,
    heldout,
    model: str = "mlp",
    noise_sigma_m: float = 0.0,
    seed: int = 0,
    hidden=(20, 20),
    epochs: int | None = None,
    batch: int = 25,
    n_initial: int | None = None,
    algorithm: str = "lm",
    tracking: bool = True,
    n_points: int = 24,
    samples_per_hour: float,
) -> dict:
    """One row: draw ``n`` commands by ``strategy``, measure the body's tips, fit ``model``, evaluate it.

    Parameters
    ----------
    body : NominalBody or AsBuiltBody
        The body measured (:func:`make_body`).
    strategy, n, levels : str, int, int or None
        Sampling strategy (:data:`lab.studies.data_curve_plan.STRATEGIES`); number of samples; a grid's levels per motor
        (whose safe count ``n`` is; None for the other strategies).
    heldout : tuple
        ``(u (H, m) rad, settled tips (H, 3) m, fingerprint)`` (:func:`heldout_set`).
    model, algorithm : str, optional
        Forward model (:data:`lab.studies.data_curve_plan.MODELS`) and the rule that trains it
        (and the active sampler's ensemble).
    noise_sigma_m, seed : float, int, optional
        Measurement noise per axis (m); seed of the draw, the noise and the fit.
    hidden, epochs : tuple of int, int, optional
        Hidden layer widths; epoch cap (None: the trainer's).
    batch, n_initial : int, optional
        The active sampler's batch size and initial draw (None: the sampler's default).
    tracking, n_points : bool, int, optional
        Track Table I's shapes with ``n_points`` targets each (else the shapes' errors are NaN).
    samples_per_hour : float
        Capture rate that turns N into ``capture_h``.

    Returns
    -------
    dict
        ``strategy, n, grid_levels, seed, model, model_error_m``, each ``{shape}_m``,
        ``tracking_mean_m`` (m), ``fit_s``, ``design_s`` (s), ``capture_h`` (h), ``heldout_id``.
    """
    t0 = time.perf_counter()
    u, y = draw_and_measure(
        body, strategy, n, levels, noise_sigma_m=noise_sigma_m, seed=seed,
        opts={"batch": batch, "n_initial": n_initial, "hidden": hidden, "epochs": epochs, "algorithm": algorithm},
    )  # fmt: skip
    t_design = time.perf_counter() - t0
    if len(u) != n:
        raise InputError(f"{strategy}: drew {len(u)} commands for N = {n}")
    t0 = time.perf_counter()
    fitted = fit_forward_model(model, u, y, hidden=hidden, seed=seed, epochs=epochs, algorithm=algorithm)
    t_fit = time.perf_counter() - t0
    u_test, tips_test, fingerprint = heldout
    if tracking:
        ev = evaluate_model(fitted, body, u_test, tips_test, n_points)
    else:
        err = np.linalg.norm(fitted.predict(u_test) - tips_test, axis=1)
        ev = {"model_error_m": float(np.mean(err)), "tracking_mean_m": float("nan")}
        ev.update({f"{s}_m": float("nan") for s in SHAPES})
    return {
        "strategy": strategy,
        "n": int(n),
        "grid_levels": "" if levels is None else int(levels),
        "seed": int(seed),
        "model": model,
        "model_error_m": ev["model_error_m"],
        **{f"{s}_m": ev[f"{s}_m"] for s in SHAPES},
        "tracking_mean_m": ev["tracking_mean_m"],
        "fit_s": t_fit,
        "design_s": t_design,
        "capture_h": n / samples_per_hour,
        "heldout_id": fingerprint,
    }
