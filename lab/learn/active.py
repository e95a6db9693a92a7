"""Active sampling: measure, batch after batch, the allowed commands where a model ensemble disagrees most.

:func:`active_sampling`, with the settings of an :class:`ActiveSpec`, starts from a
scrambled-Sobol design of ``n_initial`` safe commands, then until ``n_total`` samples are
measured: fits an ensemble of ``k`` networks to all ``(u, y)`` so far; scores a fresh,
seeded pool of ``pool_size`` safe Sobol candidates by the ensemble's spread (m) times
their density in the pool (:func:`pool_density`: the spread alone crowds the picks on the
safe set's boundary);
picks ``batch`` of them apart from each other and from the data (:func:`pick_apart`);
measures them with the caller's ``measure(u_batch) -> y_batch`` (the simulator or a rig).
Every random choice is seeded by ``(seed, number of samples so far)``, so a run killed
after some batches and restarted with the data it had measured (``u_done``, ``y_done``)
continues exactly as the uninterrupted run, given a deterministic ensemble fit. Why these
choices, with their measured effect: ``docs/design/sampling.md``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from lab.data.designs import sobol_commands
from lab.description import RobotDescription
from lab.errors import InputError, LabRuntimeError

#: Largest candidate pool (a Sobol draw, and one ensemble prediction each batch).
MAX_POOL = 1_000_000


def default_initial(n_total: int) -> int:
    """Samples of the initial Sobol design: half of ``n_total`` (at least 1). Half was
    better than 30 (three-cable FEM on a 1x6 mesh, N = 200: 1.50 against 1.63 mm held-out
    error) and as good as three quarters: the spread is a weak guide while data are few."""
    return int(max(1, n_total // 2))


def pool_density(x_pool: np.ndarray, radius: float) -> np.ndarray:
    """Per candidate of ``x_pool`` (P, m), the number of candidates within ``radius`` of it
    (itself included) over the largest such number: (P,) in (0, 1]."""
    from scipy.spatial import cKDTree

    count = cKDTree(x_pool).query_ball_point(x_pool, radius, return_length=True).astype(float)
    return count / count.max()


def default_radius(n_total: int, n_motors: int) -> float:
    """Half the spacing of ``n_total`` points spread over the unit box ``[0, 1]^m``:
    ``0.5 n_total^(-1/m)`` (in ``u / u_max``)."""
    return 0.5 * float(n_total) ** (-1.0 / n_motors)


def pick_apart(x_pool: np.ndarray, spread: np.ndarray, x_data: np.ndarray, n: int, radius: float) -> np.ndarray:
    """Indices (n,) of ``n`` candidates of ``x_pool`` (P, m) chosen greedily by score
    ``spread * min(1, d / radius)``, ``d`` the distance of a candidate to the nearest row
    of ``x_data`` (N, m) or candidate already picked; ``spread`` (P,) >= 0. Ties: the
    lowest index. Same units for ``x_pool``, ``x_data`` and ``radius``.

    Parameters
    ----------
    x_pool : numpy.ndarray
        Candidates, shape (P, m), e.g. commands in rad.
    spread : numpy.ndarray
        The model's spread at each candidate, shape (P,), >= 0.
    x_data : numpy.ndarray
        Points already sampled, shape (N, m).
    n : int
        Candidates to pick (<= P).
    radius : float
        Distance below which a candidate's score shrinks, units of ``x_pool``.

    Returns
    -------
    numpy.ndarray
        Indices into ``x_pool``, shape (n,), int, in the order picked.
    """
    x_pool, spread = np.asarray(x_pool, float), np.asarray(spread, float)
    if n > len(x_pool):
        raise InputError(f"cannot pick {n} of a pool of {len(x_pool)}")
    d = np.full(len(x_pool), np.inf)
    for start in range(0, len(x_data), 1024):  # blocks: P x 1024 distances at a time
        block = np.asarray(x_data[start : start + 1024], float)
        d = np.minimum(d, np.linalg.norm(x_pool[:, None, :] - block[None], axis=2).min(axis=1))
    picked = []
    for _ in range(n):
        score = spread * np.minimum(1.0, d / radius)
        score[picked] = -np.inf
        i = int(np.argmax(score))
        picked.append(i)
        np.minimum(d, np.linalg.norm(x_pool - x_pool[i], axis=1), out=d)
    return np.asarray(picked, dtype=int)


def _seeds(seed: int, n_so_far: int) -> tuple[int, int]:
    """(pool seed, fit seed) for the batch that follows ``n_so_far`` samples."""
    a, b = np.random.SeedSequence([seed, n_so_far]).generate_state(2)
    return int(a), int(b)


def _check_int(name: str, v, low: int) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < low:
        raise InputError(f"active sampling needs an integer {name} >= {low}, got {v!r}")
    return int(v)


def _measured(measure, u_batch: np.ndarray) -> np.ndarray:
    y = np.asarray(measure(u_batch), dtype=float)
    if y.shape != (len(u_batch), 3) or not np.all(np.isfinite(y)):
        raise LabRuntimeError(f"measure() must return finite tips ({len(u_batch)}, 3) m, got shape {y.shape}")
    return y


@dataclass(frozen=True)
class ActiveSpec:
    """The settings of one active-sampling run (module docstring), checked.

    Parameters
    ----------
    n_total : int
        Samples to measure in all, >= 1.
    batch : int
        Samples per active batch (the last may be smaller), >= 1.
    n_initial : int, optional
        Size of the initial Sobol design, <= ``n_total`` (None: :func:`default_initial`, half).
    pool_size : int
        Safe Sobol candidates scored per batch, ``batch`` <= pool_size <= :data:`MAX_POOL`.
    hidden : tuple of int
        Hidden widths of the ensemble's members.
    k : int
        Ensemble members, >= 2.
    seed : int
        Seed of every random choice (with the number of samples so far), >= 0.
    epochs : int, optional
        The members' maximum epochs (None: the trainer's default).
    radius : float, optional
        :func:`pick_apart`'s radius in ``u / u_max`` (None: :func:`default_radius`).
    density_radius : float, optional
        :func:`pool_density`'s radius in ``u / u_max`` (None: score by spread alone).

    Raises
    ------
    InputError
        For a setting out of its range.
    """

    n_total: int
    batch: int
    n_initial: int | None = None
    pool_size: int = 4096
    hidden: tuple[int, ...] = (20, 20)
    k: int = 5
    seed: int = 0
    epochs: int | None = None
    radius: float | None = None
    density_radius: float | None = 0.3

    def __post_init__(self):
        n_total, batch = _check_int("n_total", self.n_total, 1), _check_int("batch", self.batch, 1)
        n_initial = default_initial(n_total) if self.n_initial is None else _check_int("n_initial", self.n_initial, 1)
        if n_initial > n_total:
            raise InputError(f"active sampling: n_initial = {n_initial} exceeds n_total = {n_total}")
        pool_size, k = _check_int("pool_size", self.pool_size, batch), _check_int("k", self.k, 2)
        if pool_size > MAX_POOL:
            raise InputError(f"active sampling: pool_size = {pool_size} exceeds {MAX_POOL}")
        seed = _check_int("seed", self.seed, 0)
        radius, density_radius = self.radius, self.density_radius
        if (radius is not None and not radius > 0) or (density_radius is not None and not density_radius > 0):
            raise InputError(
                f"active sampling: radius and density_radius must be positive, got {radius}, {density_radius}"
            )
        for name, value in (("n_total", n_total), ("batch", batch), ("n_initial", n_initial), ("pool_size", pool_size),
                            ("k", k), ("seed", seed), ("hidden", tuple(self.hidden))):  # fmt: skip
            object.__setattr__(self, name, value)


def active_sampling(
    robot: RobotDescription,
    measure,
    spec: ActiveSpec,
    *,
    u_done=None,
    y_done=None,
    fit_ensemble=None,
    on_pick=None,
    on_batch=None,
) -> tuple[np.ndarray, np.ndarray, list[dict]]:
    """Measure ``spec.n_total`` safe commands chosen where an ensemble disagrees (module docstring).

    Parameters
    ----------
    robot : RobotDescription
        Its safe set and ``u_max_rad`` bound the commands.
    measure : callable
        ``measure(u_batch (B, m) rad) -> y (B, 3) m`` measures a batch.
    spec : ActiveSpec
        The run's settings.
    u_done, y_done : array_like, shape (N, m) rad and (N, 3) m, optional
        Samples of an earlier run of the same settings to continue from (none: start
        with the initial design).
    fit_ensemble : callable, optional
        ``fit_ensemble(u, y, hidden=, k=, seed=, epochs=)`` returns an object with
        ``predict_with_std(u (P, m)) -> (mean (P, 3), std (P, 3))`` m (default
        :func:`lab.learn.ensemble.train_ensemble`).
    on_pick : callable, optional
        ``on_pick(u_batch, entry)``, called before each batch (the initial design
        included) is measured, e.g. to journal the plan.
    on_batch : callable, optional
        ``on_batch(u_batch, y_batch, entry)``, called after, e.g. to save the batch.

    Returns
    -------
    u : numpy.ndarray, shape (n_total, m)
        Commands (rad): ``u_done`` first, then each batch in the order picked.
    y : numpy.ndarray, shape (n_total, 3)
        Their tips (m).
    log : list of dict
        The batches measured by this call: ``batch`` (0: the initial design), ``kind``
        ("initial" or "active"), ``n_before``, ``n`` and, for active batches, the seeds,
        the pool's and the picks' mean and max spread (m) and ``fit_s``.
    """
    if not isinstance(spec, ActiveSpec):
        raise InputError(f"spec must be an ActiveSpec, got {type(spec).__name__}")
    m = robot.n_inputs
    n_total, batch, pool_size, seed = spec.n_total, spec.batch, spec.pool_size, spec.seed
    n_initial = default_initial(n_total) if spec.n_initial is None else spec.n_initial
    hidden, k, epochs, density_radius = spec.hidden, spec.k, spec.epochs, spec.density_radius
    radius = default_radius(n_total, m) if spec.radius is None else float(spec.radius)
    if fit_ensemble is None:
        from lab.learn.ensemble import train_ensemble as fit_ensemble
    u = np.empty((0, m)) if u_done is None else np.asarray(u_done, dtype=float).reshape(-1, m)
    y = np.empty((0, 3)) if y_done is None else np.asarray(y_done, dtype=float).reshape(-1, 3)
    if len(u) != len(y) or len(u) > n_total or not np.all(robot.is_safe(u)):
        raise InputError(
            f"u_done ({len(u)}) and y_done ({len(y)}) must be the same number (<= n_total = {n_total}) "
            "of safe commands and their tips"
        )
    log = []

    def add(u_b, entry):
        nonlocal u, y
        if on_pick is not None:
            on_pick(u_b, entry)
        y_b = _measured(measure, u_b)
        u, y = np.vstack([u, u_b]), np.vstack([y, y_b])
        log.append(entry)
        if on_batch is not None:
            on_batch(u_b, y_b, entry)

    if len(u) == 0:
        u_b = sobol_commands(robot, n_initial, seed=seed)
        entry = {"batch": 0, "kind": "initial", "design": "sobol", "n_before": 0, "n": n_initial}
        add(u_b, entry)
    while len(u) < n_total:
        n_b = min(batch, n_total - len(u))
        pool_seed, fit_seed = _seeds(seed, len(u))
        pool = sobol_commands(robot, pool_size, seed=pool_seed)
        t0 = time.perf_counter()
        ensemble = fit_ensemble(u, y, hidden=tuple(hidden), k=k, seed=fit_seed, epochs=epochs)
        _, std = ensemble.predict_with_std(pool)
        fit_s = time.perf_counter() - t0
        spread = np.linalg.norm(np.asarray(std, dtype=float).reshape(len(pool), -1), axis=1)
        x_pool = pool / robot.u_max_rad
        score = spread if density_radius is None else spread * pool_density(x_pool, density_radius)
        picks = pick_apart(x_pool, score, u / robot.u_max_rad, n_b, radius)
        u_b = pool[picks]
        entry = {
            "batch": 1 + -(-(len(u) - n_initial) // batch),  # the initial design is batch 0
            "kind": "active",
            "n_before": len(u),
            "n": n_b,
            "pool_seed": pool_seed,
            "fit_seed": fit_seed,
            "pool_spread_mean_m": float(spread.mean()),
            "pool_spread_max_m": float(spread.max()),
            "picked_spread_mean_m": float(spread[picks].mean()),
            "picked_spread_max_m": float(spread[picks].max()),
            "fit_s": fit_s,
        }
        add(u_b, entry)
    return u, y, log
