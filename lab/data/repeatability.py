"""How repeatable a robot is: the tip spread no static model u -> y can explain, and hysteresis.

A static model predicts one tip ``f(u)`` per command. If the robot lands at
``y_i = f(u_i) + e_i`` with a deviation ``e_i`` that depends on more than the command (the
path it came by, friction, the session), even the best static model is off by
``e_i``. The *repeatability floor* is its RMS 3-D size, ``sqrt(E|e|^2)``, estimated from
pairs of rows whose commands are equal or nearly so: for pairs at scaled command distance
``d``, ``E|y_i - y_j|^2 = 2 E|e|^2 + c d^2 + ...``, so the intercept at ``d = 0`` of a fit
of the squared tip difference on ``d^2`` is ``2 E|e|^2`` (exact revisits sit at ``d = 0``
and pin it). :func:`hysteresis` asks how much of the near pairs' tip difference the
difference of their *previous* commands explains. Commands are compared after scaling each
motor by the data's range (:func:`scaled_commands`); :func:`local_residuals` is the local
fit (the mean of nearby rows) that drift and outliers are measured from. The page: ``docs/real-data.md``.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "scaled_commands",
    "neighbour_pairs",
    "revisit_floor",
    "local_residuals",
    "pair_fit",
    "repeatability_floor",
    "hysteresis",
]

#: Fewer pairs than this and an estimate is not made (``None`` with a reason).
MIN_PAIRS = 10
#: Pairs drawn into the report for the figure (the fit uses all of them).
SAMPLE_PAIRS = 1500


def scaled_commands(u_motor: np.ndarray) -> np.ndarray:
    """Commands mapped per motor to [0, 1] by the data's range (a constant motor: 0).

    Parameters
    ----------
    u_motor : numpy.ndarray
        Commands (N, m), rad (or the data's input unit).

    Returns
    -------
    numpy.ndarray
        Scaled commands (N, m), dimensionless.
    """
    u = np.asarray(u_motor, float)
    span = u.max(0) - u.min(0)
    return (u - u.min(0)) / np.where(span > 0, span, 1.0)


def neighbour_pairs(u_motor: np.ndarray, neighbours: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pairs of rows with equal or nearby commands: each row with its ``neighbours`` nearest
    rows in scaled command space, plus every pair of exact revisits (commands equal to 1e-9
    of each motor's range).

    Parameters
    ----------
    u_motor : numpy.ndarray
        Commands (N, m), rad (or the data's input unit).
    neighbours : int
        Nearest rows per row.

    Returns
    -------
    pairs : numpy.ndarray
        (P, 2) int with ``i < j``, each pair once.
    distance : numpy.ndarray
        (P,) their scaled command distance (dimensionless, a motor's whole range is 1).
    exact : numpy.ndarray
        (P,) bool: an exact revisit.
    """
    from scipy.spatial import cKDTree

    z = scaled_commands(u_motor)
    n = len(z)
    k = min(neighbours, n - 1)
    found = [np.empty((0, 2), int)]
    if k >= 1:
        _, nbr = cKDTree(z).query(z, k + 1)
        i = np.repeat(np.arange(n), k)
        j = nbr[:, 1:].ravel()
        found.append(np.column_stack([i, j]))
    _, group, count = np.unique(np.round(z, 9), axis=0, return_inverse=True, return_counts=True)
    group = group.ravel()
    for g in np.flatnonzero(count > 1):
        rows = np.flatnonzero(group == g)
        a, b = np.triu_indices(len(rows), 1)
        found.append(np.column_stack([rows[a], rows[b]]))
    pairs = np.unique(np.sort(np.vstack(found), axis=1), axis=0)
    pairs = pairs[pairs[:, 0] != pairs[:, 1]]
    distance = np.linalg.norm(z[pairs[:, 0]] - z[pairs[:, 1]], axis=1)
    exact = group[pairs[:, 0]] == group[pairs[:, 1]]
    return pairs, distance, exact


def revisit_floor(u_motor: np.ndarray, p_tip_W: np.ndarray) -> float | None:
    """The floor from exact revisits alone (m): ``sqrt(mean |y_i - y_j|^2 / 2)`` over every
    pair of rows whose commands are equal (:func:`neighbour_pairs`' ``exact``); each pair's
    half squared distance estimates the per-row tip variance without bias. None without revisits."""
    pairs, _, exact = neighbour_pairs(u_motor, 0)
    if not exact.any():
        return None
    diff = np.asarray(p_tip_W, float)[pairs[exact, 0]] - np.asarray(p_tip_W, float)[pairs[exact, 1]]
    return float(np.sqrt(np.mean(np.sum(diff**2, axis=1)) / 2))


def local_residuals(u_motor: np.ndarray, values: np.ndarray, neighbours: int, groups=None) -> np.ndarray:
    """Each row's values minus their mean over the row's nearest rows outside its own group.

    Parameters
    ----------
    u_motor : numpy.ndarray
        Commands (N, m), rad (or the data's input unit).
    values : numpy.ndarray
        (N, c), e.g. the tip (m).
    neighbours : int
        Nearest rows (scaled command space) in each mean.
    groups : numpy.ndarray, optional
        (N,) int; None: leave one row out.

    Returns
    -------
    numpy.ndarray
        Residuals (N, c), units of ``values``; NaN for a row without such a neighbour.
    """
    from scipy.spatial import cKDTree

    z, y = scaled_commands(u_motor), np.asarray(values, float)
    y = y.reshape(len(y), -1)
    n = len(z)
    groups = np.arange(n) if groups is None else np.asarray(groups)
    extra = int(np.bincount(np.unique(groups, return_inverse=True)[1]).max())
    k = min(neighbours + extra, n)
    tree, out = cKDTree(z), np.full(y.shape, np.nan)
    step = max(1, 2_000_000 // k)
    for lo in range(0, n, step):
        rows = np.arange(lo, min(lo + step, n))
        _, nbr = tree.query(z[rows], k)
        nbr = nbr.reshape(len(rows), k)
        other = groups[nbr] != groups[rows][:, None]
        take = other & (np.cumsum(other, axis=1) <= neighbours)
        count = take.sum(1)
        total = np.einsum("rk,rkc->rc", take, y[nbr])
        has = count > 0
        out[rows[has]] = y[rows[has]] - total[has] / count[has, None]
    return out


def pair_fit(d2: np.ndarray, dy2: np.ndarray, iterations: int = 3) -> tuple[float, float]:
    """Fit ``E[dy2] = a + b d2`` by weighted least squares with weights ``1 / fitted^2`` (the
    squared difference of Gaussian deviations has a spread proportional to its mean).
    ``d2``: squared scaled command distances (P,); ``dy2``: squared tip differences (P,) m^2.
    Returns ``(a, b)``: the intercept (m^2) and the slope (m^2 per unit d^2); NaN when
    the distances do not spread (no line can be drawn)."""
    x = np.column_stack([np.ones_like(d2), d2])
    if np.ptp(d2) <= 1e-6 * np.max(d2, initial=0.0):
        return (float(np.mean(dy2)), float("nan")) if np.all(d2 == 0) else (float("nan"), float("nan"))
    w = np.ones_like(d2)
    low = 1e-3 * max(float(np.mean(dy2)), 1e-30)
    for _ in range(iterations + 1):
        coef = np.linalg.solve((x * w[:, None]).T @ x, (x * w[:, None]).T @ dy2)
        w = 1.0 / np.maximum(x @ coef, low) ** 2
    return float(coef[0]), float(coef[1])


def _floor_of(d2, dy2) -> float:
    a, _ = pair_fit(d2, dy2)
    return float(np.sqrt(max(a, 0.0) / 2.0)) if np.isfinite(a) else float("nan")


def _estimate(d2, dy2, bootstrap: int, rng, tick=None) -> dict:
    """The floor (m) from these pairs, with a 95 % bootstrap interval over pairs;
    ``tick(1)`` after each resample."""
    n = len(d2)
    if n < MIN_PAIRS:
        return {"floor_m": None, "interval_m": None, "n_pairs": int(n), "reason": f"fewer than {MIN_PAIRS} pairs"}
    floor = _floor_of(d2, dy2)
    if not np.isfinite(floor):
        reason = "all pairs are at one command distance (a grid?): no line to extrapolate; try more --neighbours"
        return {"floor_m": None, "interval_m": None, "n_pairs": int(n), "reason": reason}
    draws = []
    for _ in range(bootstrap):
        s = rng.integers(0, n, n)
        draws.append(_floor_of(d2[s], dy2[s]))
        if tick is not None:
            tick(1)
    draws = np.asarray([v for v in draws if np.isfinite(v)])
    interval = [float(q) for q in np.quantile(draws, [0.025, 0.975])] if len(draws) else None
    return {"floor_m": floor, "interval_m": interval, "n_pairs": int(n)}


def repeatability_floor(
    u_motor: np.ndarray,
    p_tip_W: np.ndarray,
    seq_ids: np.ndarray,
    *,
    neighbours: int = 5,
    bootstrap: int = 200,
    seed: int = 0,
    tick=None,
) -> dict:
    """The repeatability floor of data ``u_motor`` (N, m), ``p_tip_W`` (N, 3) m, measured in
    sequences ``seq_ids`` (N,) int: the RMS 3-D distance ``sqrt(E|y_i - f(u_i)|^2)`` (m)
    that the best static model ``f`` would still make, from :func:`neighbour_pairs`.

    Returns a JSON-ready dict: ``floor_m``, ``interval_m`` (95 % bootstrap over pairs),
    ``n_pairs``, ``n_exact_pairs``; the same estimate from ``revisits`` only (``d = 0``), for
    ``same_sequence`` and ``cross_sequence`` pairs; ``immediate_repeats`` (the same command
    twice in a row: measurement noise, RMS 3-D); the fit (``intercept_m2``, ``slope_m2``);
    ``per_axis_m`` (x, y, z); ``min_distance``: the nearest pair that is not an exact revisit
    (without revisits the floor is extrapolated from there to 0); ``bins`` and ``sample``
    (distance, tip difference) for a figure.

    Parameters
    ----------
    u_motor : numpy.ndarray
        Commands (N, m), rad (or the data's input unit).
    p_tip_W : numpy.ndarray
        Tips (N, 3), m, frame W.
    seq_ids : numpy.ndarray
        Sequence number (N,) int of each row.
    neighbours, bootstrap, seed : int
        Nearest rows per row, bootstrap resamples, and the bootstrap's seed.
    tick : callable, optional
        ``tick(0)`` as the resampling starts, then ``tick(w)`` after each bootstrap resample,
        w the share of the pairs resampled (up to 2 ``bootstrap`` in all); it only observes.

    Returns
    -------
    dict
        JSON-ready, as above; lengths in m.
    """
    y = np.asarray(p_tip_W, float)
    seq = np.asarray(seq_ids)
    rng = np.random.default_rng(seed)
    pairs, dist, exact = neighbour_pairs(u_motor, neighbours)
    diff = y[pairs[:, 0]] - y[pairs[:, 1]]
    dy2, d2 = np.sum(diff**2, axis=1), dist**2
    same = seq[pairs[:, 0]] == seq[pairs[:, 1]]
    if tick is not None:
        tick(0)  # the loops start: the pairs are found
    out = _estimate(d2, dy2, bootstrap, rng, tick)
    a, b = pair_fit(d2, dy2) if len(d2) >= MIN_PAIRS else (float("nan"), float("nan"))
    immediate = exact & same & (pairs[:, 1] - pairs[:, 0] == 1)
    out.update(
        definition="RMS 3-D distance sqrt(E|y_i - f(u_i)|^2) between a measured tip and the best static "
        "prediction f(u_i) = E[y | u_i]; estimated as sqrt(a / 2), a the intercept at command distance 0 of "
        "E|y_i - y_j|^2 = a + b d^2 over pairs of nearby rows",
        n_exact_pairs=int(exact.sum()),
        revisits=_estimate(d2[exact], dy2[exact], bootstrap, rng, tick and (lambda n: tick(n * exact.mean()))),
        same_sequence=_estimate(d2[same], dy2[same], bootstrap, rng, tick and (lambda n: tick(n * same.mean()))),
        cross_sequence=_estimate(d2[~same], dy2[~same], bootstrap, rng, tick and (lambda n: tick(n - n * same.mean()))),
        immediate_repeats={
            "n_pairs": int(immediate.sum()),
            "rms_m": float(np.sqrt(dy2[immediate].mean() / 2)) if immediate.any() else None,
        },
        intercept_m2=a if np.isfinite(a) else None,
        slope_m2=b if np.isfinite(b) else None,
        per_axis_m=[_finite_or_none(_floor_of(d2, diff[:, k] ** 2)) for k in range(3)]
        if len(d2) >= MIN_PAIRS
        else None,
        bins=_bins(d2, dy2),
        min_distance=float(dist[~exact].min()) if np.any(~exact) else None,
        sample=_sample(rng, keep=exact, d2=d2, dy=np.sqrt(dy2), exact=exact, same=same),
    )
    return out


def _finite_or_none(v):
    return float(v) if v is not None and np.isfinite(v) else None


def _bins(d2, dy2, n_bins: int = 12) -> dict:
    """Mean squared tip difference (m^2) per bin of squared command distance (equal counts)."""
    if len(d2) == 0:
        return {"d2": [], "dy2_m2": [], "count": []}
    edges = np.unique(np.quantile(d2, np.linspace(0, 1, n_bins + 1)))
    which = np.clip(np.searchsorted(edges, d2, side="right") - 1, 0, max(len(edges) - 2, 0))
    keep = [k for k in range(max(len(edges) - 1, 1)) if np.any(which == k)]
    return {
        "d2": [float(d2[which == k].mean()) for k in keep],
        "dy2_m2": [float(dy2[which == k].mean()) for k in keep],
        "count": [int(np.sum(which == k)) for k in keep],
    }


def _sample(rng, keep=None, **columns) -> dict:
    """At most :data:`SAMPLE_PAIRS` entries of ``columns`` (arrays of one length), drawn at
    random, with every entry where ``keep`` (bool) is true."""
    n = len(next(iter(columns.values())))
    keep = np.zeros(n, bool) if keep is None else np.asarray(keep, bool)
    rest = np.flatnonzero(~keep)
    extra = rng.choice(rest, min(len(rest), max(SAMPLE_PAIRS - int(keep.sum()), 0)), replace=False)
    take = np.sort(np.r_[np.flatnonzero(keep), extra]).astype(int)
    return {k: [v.item() for v in np.asarray(col)[take]] for k, col in columns.items()}


def _explained(x, dy, press: bool = True):
    """Residual sum of squares of ``dy`` (P, 3) on ``x`` (P, q), its leave-one-out (PRESS)
    sum of squares (or NaN when ``press`` is false) and the coefficients (q, 3)."""
    gram_inv = np.linalg.pinv(x.T @ x)
    coef = gram_inv @ (x.T @ dy)
    res = dy - x @ coef
    if not press:
        return float(np.sum(res**2)), float("nan"), coef
    h = np.einsum("ij,jk,ik->i", x, gram_inv, x)
    return float(np.sum(res**2)), float(np.sum((res / np.maximum(1 - h, 1e-9)[:, None]) ** 2)), coef


def hysteresis(
    u_motor: np.ndarray,
    p_tip_W: np.ndarray,
    seq_ids: np.ndarray,
    pairs: np.ndarray,
    *,
    permutations: int = 200,
    seed: int = 0,
    tick=None,
) -> dict:
    """How much the previous command explains the tip difference of near pairs.

    For each pair (i, j) of ``pairs`` (P, 2) whose rows both have a predecessor in their own
    sequence (``seq_ids``), regress the tip difference ``y_i - y_j`` (m) linearly, without
    an intercept, on the current command difference ``u_i - u_j`` and the previous command
    difference ``u_{i-1} - u_{j-1}`` (units of u). Returns a JSON-ready dict: ``n_pairs``;
    ``fraction_explained``: the share of the pairs' sum of squared tip differences that adding
    the previous command removes, out of sample (leave-one-pair-out, so ~0 or below when it
    explains nothing); ``fraction_of_residual``: the same share of what the current command
    leaves unexplained; ``fraction_in_sample``; ``p_value`` (a permutation test over pairs);
    ``slope_m_per_unit``: the largest singular value of the previous-command coefficient
    (m of tip per unit of command), with ``per_motor_m_per_unit``; ``sample`` for a figure.

    Parameters
    ----------
    u_motor : numpy.ndarray
        Commands (N, m), rad (or the data's input unit).
    p_tip_W : numpy.ndarray
        Tips (N, 3), m, frame W.
    seq_ids : numpy.ndarray
        Sequence number (N,) int of each row.
    pairs : numpy.ndarray
        Near pairs (P, 2) of row indices (:func:`neighbour_pairs`).
    permutations, seed : int
        Permutations of the test, and their seed.
    tick : callable, optional
        ``tick(1)`` after each permutation; it only observes.

    Returns
    -------
    dict
        JSON-ready, as above.
    """
    u, y, seq = np.asarray(u_motor, float), np.asarray(p_tip_W, float), np.asarray(seq_ids)
    m = u.shape[1]
    i, j = pairs[:, 0], pairs[:, 1]
    ok = (i > 0) & (j > 0)
    ok[ok] &= (seq[i[ok] - 1] == seq[i[ok]]) & (seq[j[ok] - 1] == seq[j[ok]])
    i, j = i[ok], j[ok]
    if len(i) < max(MIN_PAIRS, 4 * m):
        return {"n_pairs": int(len(i)), "fraction_explained": None, "reason": "too few pairs with a previous command"}
    dy = y[i] - y[j]
    x = np.hstack([u[i] - u[j], u[i - 1] - u[j - 1]])
    total = float(np.sum(dy**2))
    if total == 0:
        return {"n_pairs": int(len(i)), "fraction_explained": None, "reason": "the near pairs' tips do not differ"}
    rss_u, press_u, _ = _explained(x[:, :m], dy)
    rss, press, coef = _explained(x, dy)
    rng = np.random.default_rng(seed)
    null = []
    for _ in range(permutations):
        xp = np.hstack([x[:, :m], x[rng.permutation(len(x)), m:]])
        null.append(rss_u - _explained(xp, dy, press=False)[0])
        if tick is not None:
            tick(1)
    slope = coef[m:]  # (m, 3): tip (m) per unit of previous command
    gain = x[:, m:] @ slope
    return {
        "n_pairs": int(len(i)),
        "fraction_explained": (press_u - press) / total,
        "fraction_of_residual": (press_u - press) / press_u,
        "fraction_in_sample": (rss_u - rss) / total,
        "p_value": float((1 + np.sum(np.asarray(null) >= rss_u - rss)) / (permutations + 1)),
        "slope_m_per_unit": float(np.linalg.norm(slope, 2)),
        "per_motor_m_per_unit": [float(v) for v in np.linalg.norm(slope, axis=1)],
        "sample": _sample(
            rng,
            previous_distance=np.linalg.norm(x[:, m:], axis=1),
            dy=np.linalg.norm(dy, axis=1),
            dy_explained=np.linalg.norm(gain, axis=1),
        ),
    }
