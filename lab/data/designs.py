"""Which motor commands to sample.

Samplers give safe commands (N, m), each input in its unit (a spool angle in rad, a tension
in N) and within its range ``[robot.u_lower, robot.u_upper]`` (the box written [0, u_max]^m
below, as for today's angle-controlled robots, whose every input spans [0, u_max_rad]):
:func:`grid_commands` (``levels`` equally spaced values per input, the paper's 7x7x7 grid,
minus what the safety rule forbids), :func:`sobol_commands` (a scrambled Sobol sequence, seeded),
:func:`lhs_commands` (a Latin hypercube, seeded, restricted to the safe set) and
:func:`design_commands` (``n`` commands of a ``"random"``, ``"sobol"``, ``"maximin"``
(:func:`maximin_commands`, its selection in :mod:`lab.data.maximin`) or ``"lhs"`` design
over the safe set, for capturing a few real samples); :func:`min_distance` scores a design
(its smallest pairwise distance), :func:`empty_strata` its stratification.

Prefixes: the random, Sobol and maximin designs are prefix-stable -- the first k commands of
a design of any length are the design of length k (same seed) -- so a study may take its N
samples as the first N of one long design and still use, at every N, the commands a design
of N would. A Latin hypercube is not: its strata are n equal slices per motor, so a design
of 10 is no prefix of one of 50.

The walks (chunks) the commands are solved in: :mod:`lab.data.chunks`.
"""

from __future__ import annotations

import itertools

import numpy as np

from lab.data.maximin import greedy_maximin, maximin_pool_size
from lab.description import RobotDescription
from lab.errors import InputError


def _input_box(robot: RobotDescription) -> tuple[np.ndarray, np.ndarray]:
    """Each input's range, ``robot.u_lower`` and ``robot.u_upper`` (m,) float, in its unit."""
    return np.asarray(robot.u_lower, float), np.asarray(robot.u_upper, float)


def _unit_scale(robot: RobotDescription, u: np.ndarray) -> np.ndarray:
    """Commands (N, m) mapped to [0, 1]^m by each input's range (``u / u_max`` for today's robots)."""
    lo, hi = _input_box(robot)
    span = hi - lo
    return (np.asarray(u, dtype=float) - lo) / np.where(span > 0, span, 1.0)


def grid_commands(robot: RobotDescription, levels: int) -> np.ndarray:
    """Safe points of the ``levels**m`` grid over [0, u_max]^m, in lexicographic order.

    Parameters
    ----------
    robot : RobotDescription
        Gives m, each input's range and the safety rule.
    levels : int
        Angles per motor, >= 2.

    Returns
    -------
    numpy.ndarray
        The commands (N, m), rad.
    """
    if levels < 2:
        raise InputError("a grid needs at least 2 levels per motor")
    lo, hi = _input_box(robot)
    axes = [np.linspace(lo[j], hi[j], levels) for j in range(robot.n_inputs)]
    u = np.array(list(itertools.product(*axes)))
    return u[robot.is_safe(u)]


def sobol_commands(robot: RobotDescription, n: int, seed: int = 0) -> np.ndarray:
    """Safe commands from a scrambled Sobol sequence over [0, u_max]^m: its safe points in
    the sequence's order, so the first k of ``n`` are those of a draw of k (prefix-stable).

    Parameters
    ----------
    robot : RobotDescription
        Gives m, each input's range and the safety rule.
    n, seed : int
        Number of commands, and the scrambling's seed.

    Returns
    -------
    numpy.ndarray
        The commands (n, m), rad.
    """
    from scipy.stats import qmc

    sampler = qmc.Sobol(d=robot.n_inputs, scramble=True, seed=seed)
    lo, hi = _input_box(robot)
    out = np.empty((0, robot.n_inputs))
    m = int(np.ceil(np.log2(max(64, 2 * n))))
    while len(out) < n:
        if m > 22:  # 4 million candidates and still short
            raise InputError(f"{robot.name}: its safety rule leaves almost no command; cannot draw {n}")
        u = lo + sampler.random_base2(m) * (hi - lo)
        out = np.vstack([out, u[robot.is_safe(u)]])
        m = int(np.log2(sampler.num_generated))  # the next draw doubles the sequence (balance)
    return out[:n]


#: The space-filling designs of :func:`design_commands`.
DESIGNS = ("random", "sobol", "maximin", "lhs")
#: Largest ``n`` of a random or Sobol design, and of a maximin design (whose greedy
#: selection costs n x its candidate pool).
MAX_DESIGN_N = 100_000
MAX_MAXIMIN_N = 2_000


def axis_ranges(robot: RobotDescription) -> np.ndarray:
    """Largest safe value (m,) of each input with the others at 0: ``u_upper``, or less
    where a safety limit on a set of cables holding it caps their sum lower."""
    hi = _input_box(robot)[1].copy()
    for lim in robot.safety_limits:
        for c in lim.cables:
            hi[c] = min(hi[c], lim.max_sum_over_u_max * robot.u_max_rad)
    return hi


#: How many safe commands (a scrambled-Sobol draw, seed 0) stand for the safe set's
#: per-motor (marginal) distributions in :func:`lhs_commands` and :func:`empty_strata`.
MARGINAL_SAMPLES = 65_536


def _safe_marginals(robot: RobotDescription) -> np.ndarray:
    """Per motor, the sorted angles (m, P) rad of P safe commands spread uniformly over
    the safe set: its marginal distributions (P = :data:`MARGINAL_SAMPLES`)."""
    return np.sort(sobol_commands(robot, MARGINAL_SAMPLES, seed=0), axis=0).T


def _levels(n_samples: int) -> np.ndarray:
    return (np.arange(n_samples) + 0.5) / n_samples


def empty_strata(robot: RobotDescription, u_motor: np.ndarray) -> np.ndarray:
    """Per motor, how many of ``N`` strata hold none of the ``N`` commands.

    The strata of a motor are equally likely under uniform sampling of the safe set (equal
    slices of its marginal distribution). 0 for every motor is a Latin hypercube of the
    safe set; N independent uniform draws leave about N/e empty.

    Parameters
    ----------
    robot : RobotDescription
        Gives m, each input's range and the safety rule.
    u_motor : numpy.ndarray
        The commands (N, m), rad.

    Returns
    -------
    numpy.ndarray
        Empty strata per motor (m,), int.
    """
    u = np.asarray(u_motor, dtype=float)
    marg, n = _safe_marginals(robot), len(u)
    out = []
    for j in range(u.shape[1]):
        p = np.interp(u[:, j], marg[j], _levels(marg.shape[1]))
        out.append(n - len(np.unique(np.clip(np.floor(p * n).astype(int), 0, n - 1))))
    return np.array(out)


def lhs_commands(robot: RobotDescription, n: int, seed: int = 0) -> np.ndarray:
    """``n`` safe commands (n, m) rad of a Latin hypercube of the safe set (seeded).

    The safety rule cuts the box, which a plain Latin hypercube ignores twice: some of
    its points are unsafe, and its strata (equal slices of ``[0, u_max]``) are not equally
    likely in the safe set, whose high angles are rarer (each needs the other motors low).
    So the strata are equal slices of each motor's *marginal distribution over the safe
    set* (from :data:`MARGINAL_SAMPLES` scrambled-Sobol safe commands): an ``n``-point
    Latin hypercube (:class:`scipy.stats.qmc.LatinHypercube`, scrambled) in probability is
    mapped through each marginal's quantiles and *repaired*: while a point breaks the
    rule, one of its coordinates is swapped with the same motor's coordinate of another
    point (the swap that leaves the pair the largest safety margin). Swaps permute each
    motor's values, so the result is still exactly Latin: each of the ``n`` strata of
    every motor holds one point (:func:`empty_strata` is 0). (Strata of ``[0, u_max]``
    instead gave a 1.5-1.9x larger held-out model error than Sobol at N = 200 on the
    three-cable FEM: the design crowded the safety rule's boundary.) Where no swap helps,
    it falls back to drawing larger hypercubes, keeping their safe points and dropping
    the surplus that shares strata with the most others. Order: the draw's (random) order.
    Not prefix-stable: the strata depend on ``n``, so the first k commands of an ``n``-point
    hypercube are not a k-point one (nor Latin)."""
    from scipy.stats import qmc

    m, marg = robot.n_inputs, _safe_marginals(robot)
    levels = _levels(marg.shape[1])
    rng = np.random.default_rng(seed)

    def to_u(p):
        return np.column_stack([np.interp(p[:, j], levels, marg[j]) for j in range(m)])

    u = _repair_lhs(robot, to_u(qmc.LatinHypercube(d=m, rng=rng).random(n)), rng)
    if u is not None:
        return u
    n_draw = n
    while n_draw <= 4_000_000:
        p = qmc.LatinHypercube(d=m, rng=rng).random(n_draw)
        safe = robot.is_safe(to_u(p))
        if safe.sum() >= n:
            return to_u(p[safe][_thin_by_strata(p[safe], n)])
        n_draw = int(np.ceil(1.1 * n_draw)) + 1
    raise InputError(f"{robot.name}: its safety rule leaves almost no command; cannot draw {n}")


def _repair_lhs(robot: RobotDescription, u: np.ndarray, rng, n_partners: int = 512) -> np.ndarray | None:
    """Swap coordinates between points of ``u`` (n, m) rad (within each motor's column)
    until every point is safe; None if stuck. Each step fixes the worst point if a swap
    makes it and its partner safe, else takes the swap that most reduces the total
    violation; the violation never grows, so it ends. Partners: all points, or
    ``n_partners`` drawn from ``rng`` per step for a large ``n``."""
    u = u.copy()
    n, m = u.shape
    if not robot.safety_limits or n < 2:
        return u if np.all(robot.is_safe(u)) else None
    a = np.zeros((len(robot.safety_limits), m))
    for r, lim in enumerate(robot.safety_limits):
        a[r, list(lim.cables)] = 1.0
    cap = np.array([lim.max_sum_over_u_max * robot.u_max_rad for lim in robot.safety_limits])

    def slack(x):  # (..., m) -> (...,): the smallest margin of the rule, rad (< 0: unsafe)
        return (cap - x @ a.T).min(axis=-1)

    s = slack(u)
    for _ in range(20 * n * m):
        bad = np.flatnonzero(s < 0)
        if not len(bad):
            return u if np.all(robot.is_safe(u)) else None
        i = int(bad[np.argmin(s[bad])])
        ks = np.arange(n) if n <= n_partners else np.sort(rng.choice(n, n_partners, replace=False))
        ks = ks[ks != i]
        # s_i[j, c]: margin of point i with coordinate j taken from point ks[c]; s_k[j, c]: of ks[c] with i's
        ui = np.repeat(u[i][None, None], m, axis=0).repeat(len(ks), axis=1)
        uk = np.repeat(u[ks][None], m, axis=0)
        for j in range(m):
            ui[j, :, j], uk[j, :, j] = u[ks, j], u[i, j]
        s_i, s_k = slack(ui), slack(uk)
        both = np.minimum(s_i, s_k)
        j, c = np.unravel_index(int(np.argmax(both)), both.shape)
        if both[j, c] < 0:  # no swap fixes i: the one that most reduces the total violation
            gain = np.minimum(s_i, 0) + np.minimum(s_k, 0) - min(s[i], 0) - np.minimum(s[ks], 0)[None, :]
            j, c = np.unravel_index(int(np.argmax(gain)), gain.shape)
            if gain[j, c] <= 1e-12 * float(np.max(_input_box(robot)[1])):
                return None
        k = int(ks[c])
        u[i, j], u[k, j] = u[k, j], u[i, j]
        s[i], s[k] = slack(u[i]), slack(u[k])
    return None


def _thin_by_strata(x: np.ndarray, n: int) -> np.ndarray:
    """Indices (sorted) of ``n`` of the points ``x`` (P, m) in [0, 1]^m: the surplus removed
    one at a time, each time the point whose strata (``n`` per axis) hold the most others."""
    bins = np.clip(np.floor(x * n).astype(int), 0, n - 1)
    counts = np.stack([np.bincount(bins[:, j], minlength=n) for j in range(x.shape[1])])
    keep = np.ones(len(x), bool)
    cols = np.arange(x.shape[1])
    for _ in range(len(x) - n):
        crowd = np.where(keep, (counts[cols, bins] - 1).sum(axis=1), -1)
        i = int(np.argmax(crowd))
        keep[i] = False
        counts[cols, bins[i]] -= 1
    return np.flatnonzero(keep)


def random_commands(robot: RobotDescription, n: int, seed: int = 0) -> np.ndarray:
    """Independent uniform commands over the safe part of [0, u_max]^m: the safe ones of one
    seeded stream of uniform draws, in order, so the first k of ``n`` are a draw of k (prefix-stable).

    Parameters
    ----------
    robot : RobotDescription
        Gives m, each input's range and the safety rule.
    n, seed : int
        Number of commands, and the generator's seed.

    Returns
    -------
    numpy.ndarray
        The commands (n, m), rad.
    """
    rng = np.random.default_rng(seed)
    lo, hi = _input_box(robot)
    out = np.empty((0, robot.n_inputs))
    for _ in range(1000):
        u = lo + rng.random((max(64, 2 * n), robot.n_inputs)) * (hi - lo)
        out = np.vstack([out, u[robot.is_safe(u)]])
        if len(out) >= n:
            return out[:n]
    raise InputError(f"{robot.name}: its safety rule leaves almost no command; cannot draw {n}")


def min_distance(robot: RobotDescription, u_motor: np.ndarray) -> float:
    """Smallest distance between two of the commands, in normalised command space ``u / u_max``
    (each input scaled by its range: ``(u - u_lower) / (u_upper - u_lower)``).

    Parameters
    ----------
    robot : RobotDescription
        Gives each input's range.
    u_motor : numpy.ndarray
        The commands (N, m), rad.

    Returns
    -------
    float
        The distance (dimensionless); inf for fewer than two commands.
    """
    from scipy.spatial.distance import pdist

    u = _unit_scale(robot, u_motor)
    return float(pdist(u).min()) if len(u) > 1 else float("inf")


def maximin_commands(robot: RobotDescription, n: int, seed: int = 0) -> np.ndarray:
    """Safe commands picked greedily from a growing pool of safe scrambled-Sobol candidates.

    The k-th pick chooses among the first ``max(4096, 32 k)`` safe Sobol commands (at most
    131,072; :mod:`lab.data.maximin`): first the candidate farthest from the centroid of the
    first 4096, then always the one farthest from those already picked, distances in
    normalised command space ``u / u_max``. The pool grows with the pick, not with ``n``, so
    the first k commands of a design of any length are the design of length k. Like every
    maximin design it puts its first points on the boundary of the safe set.

    Parameters
    ----------
    robot : RobotDescription
        Gives m, each input's range and the safety rule.
    n, seed : int
        Number of commands, and the pool's seed.

    Returns
    -------
    numpy.ndarray
        The commands (n, m), rad, in the order picked.
    """
    pool = sobol_commands(robot, maximin_pool_size(n), seed=seed)
    x = _unit_scale(robot, pool)
    p1 = maximin_pool_size(1)
    first = int(np.argmax(np.linalg.norm(x[:p1] - x[:p1].mean(axis=0), axis=1)))
    return pool[greedy_maximin(x, first, n, n_candidates=maximin_pool_size)]


def design_commands(robot: RobotDescription, n: int, method: str = "maximin", seed: int = 0) -> np.ndarray:
    """Safe commands of a space-filling design over the allowed set (in ``[0, u_max]^m``
    and passing the robot's safety rule). Raises InputError for an unknown method,
    ``n < 1``, ``n`` above the method's limit or a bad seed. The ``"random"``, ``"sobol"``
    and ``"maximin"`` designs are prefix-stable (the first k commands are the design of k,
    whatever ``n``); ``"lhs"`` is not (its strata depend on ``n``).

    Parameters
    ----------
    robot : RobotDescription
        Gives m, each input's range and the safety rule.
    n : int
        Number of commands, >= 1.
    method : str
        ``"random"`` (independent uniform draws), ``"sobol"`` (:func:`sobol_commands`),
        ``"maximin"`` (:func:`maximin_commands`) or ``"lhs"`` (:func:`lhs_commands`).
    seed : int
        >= 0; the design is deterministic for a given seed.

    Returns
    -------
    numpy.ndarray
        The commands (n, m), rad.
    """
    if method not in DESIGNS:
        raise InputError(f"unknown design {method!r}: expected one of {', '.join(DESIGNS)}")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise InputError(f"a {method} design needs n >= 1 commands, got {n!r}")
    limit = MAX_MAXIMIN_N if method == "maximin" else MAX_DESIGN_N
    if n > limit:
        raise InputError(f"a {method} design takes at most {limit} commands, got n = {n}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"the design's seed must be an integer >= 0, got {seed!r}")
    n, seed = int(n), int(seed)
    if method == "random":
        u = random_commands(robot, n, seed)
    elif method == "sobol":
        u = sobol_commands(robot, n, seed=seed)
    elif method == "lhs":
        u = lhs_commands(robot, n, seed=seed)
    else:
        u = maximin_commands(robot, n, seed)
    assert len(u) == n and np.all(robot.is_safe(u))
    return u
