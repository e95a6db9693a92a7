"""Error against the number of samples N, per sampling strategy (the data-efficiency study).

For one robot -- the nominal FEM (:class:`NominalBody`) or an emulated as-built robot
(:class:`lab.rig.twin.AsBuiltBody`) -- :func:`data_curve_row` draws N commands by one
sampling strategy (:data:`STRATEGIES`), measures the settled tips through the fast path
(:func:`lab.rig.twin.quasi_static_tips`, plus the robot's motion-capture noise), fits a
forward model and records ``model_error_m`` (mean distance in m on a common held-out set of
random allowed commands, noise-free), the Table I tracking error per shape and their mean
(m; :func:`lab.studies.transfer_study.evaluate_model`, optional), ``fit_s`` (s) and
``capture_h`` (N over the measured samples per hour). Each row depends only on (strategy,
N, seed) and the settings, so a study resumes row by row. :func:`smallest_n` reads off how
sparse each strategy can go, :func:`hours_saved` what that saves against the paper's 7^3
grid (308 samples). The design and its measurements: ``docs/design/studies.md``.
"""

from __future__ import annotations

import hashlib
import time
import zlib

import numpy as np

from lab.errors import InputError
from lab.rig.twin import quasi_static_tips
from lab.studies.transfer_study import SHAPES, evaluate_model, random_safe_commands

__all__ = [
    "STRATEGIES",
    "PAPER_GRID_N",
    "NominalBody",
    "make_body",
    "check_strategies",
    "check_model",
    "MODELS",
    "grid_levels_for",
    "plan_rows",
    "heldout_set",
    "fit_forward_model",
    "draw_and_measure",
    "data_curve_row",
    "smallest_n",
    "hours_saved",
]

#: Sampling strategies: a grid of L levels per motor (safe points), scrambled Sobol, Latin
#: hypercube, greedy maximin, independent uniform draws, and active sampling (batches where a
#: deep ensemble disagrees most; :func:`lab.learn.active.active_sampling`).
STRATEGIES = ("grid", "sobol", "lhs", "maximin", "random", "active")
#: The paper's training set: the safe points of the 7^3 grid of the three-cable arm.
PAPER_GRID_N = 308
#: Forward models a row can fit (:func:`fit_forward_model`; not the direct inverse, which
#: predicts no tip).
MODELS = ("mlp", "ensemble", "gpr", "knn", "sklearn-mlp")


class NominalBody:
    """The nominal FEM as a body with a quasi-static map (no lag, play or noise):
    ``quasi_static_tip(u_motor)`` is the equilibrium tip p_tip_W (3,) m at ``u_motor`` (m,) rad,
    each solve warm-started from the nearest cached one. ``n_rings``/``n_axial`` override
    the description's mesh."""

    def __init__(self, robot, *, n_rings: int | None = None, n_axial: int | None = None):
        from lab.fem.model import ArmFEM
        from lab.rig.asbuilt import EquilibriumCache

        self.robot = robot
        self.fem = ArmFEM(robot, n_rings=n_rings, n_axial=n_axial)
        self.equilibria = EquilibriumCache(self.fem)

    def quasi_static_tip(self, u_motor) -> np.ndarray:
        u = np.asarray(u_motor, dtype=float)
        return self.equilibria.tip(self.robot.spool_radius_m * u)


def make_body(robot, rig: str, *, n_rings: int | None = None, n_axial: int | None = None):
    """``(body, label, noise_sigma_m)`` for a ``--rig`` spec: ``sim`` (the nominal FEM, label
    "FEM", no noise), ``twin`` / ``twin:DEFECTS.toml`` / ``twin:random:SEED`` / ``twin:foam:SEED`` (an as-built
    body, label "emulated as-built robot", its defects' motion-capture noise in m per axis).
    The fast path needs a body: ``hardware:`` rigs are refused (InputError)."""
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


def check_strategies(strategies) -> list[str]:
    """The strategies, checked: known (:data:`STRATEGIES`) and available in this install
    (``lhs`` needs it in :data:`lab.data.designs.DESIGNS`, ``active`` needs
    :mod:`lab.learn.active`); InputError naming the problem otherwise."""
    from lab.data.designs import DESIGNS

    out = list(dict.fromkeys(strategies))
    unknown = [s for s in out if s not in STRATEGIES]
    if unknown or not out:
        raise InputError(f"unknown sampling strategy {unknown or '(none)'}: expected some of {', '.join(STRATEGIES)}")
    if "lhs" in out and "lhs" not in DESIGNS:
        raise InputError("strategy 'lhs' is not available: lab.data.designs has no Latin hypercube design")
    if "active" in out:
        try:
            from lab.learn.active import active_sampling  # noqa: F401
            from lab.learn.ensemble import train_ensemble  # noqa: F401
        except ImportError as err:
            raise InputError(f"strategy 'active' is not available in this install ({err})") from None
    return out


def check_model(name: str) -> str:
    """``name`` if it is one of :data:`MODELS` and this install can fit it, else InputError."""
    if name not in MODELS:
        raise InputError(f"unknown model {name!r}: expected one of {', '.join(MODELS)}")
    if name != "mlp":
        try:
            from lab.learn.models import fit_model  # noqa: F401
        except ImportError:
            raise InputError(f"model {name!r} is not available (lab.learn.models is missing); use mlp") from None
    return name


def grid_levels_for(robot, ns, levels=None) -> dict[int, int]:
    """``{levels: safe count}`` of the grids to measure: the given ``levels``, else for each
    N of ``ns`` the number of levels per motor whose safe count is nearest N (ties: fewer
    levels). The safe count is the N a grid row records."""
    from lab.data.designs import grid_commands

    if levels:
        bad = [lv for lv in levels if int(lv) < 2]
        if bad:
            raise InputError(f"a grid needs at least 2 levels per motor, got {bad}")
        return {int(lv): len(grid_commands(robot, int(lv))) for lv in sorted(set(levels))}
    counts, lv = {}, 2
    while True:  # counts grow with the levels; stop once past the largest N
        counts[lv] = len(grid_commands(robot, lv))
        if counts[lv] >= max(ns) or lv > 64:
            break
        lv += 1
    picked = {min(counts, key=lambda k: (abs(counts[k] - n), k)) for n in ns}
    return {k: counts[k] for k in sorted(picked)}


def plan_rows(robot, strategies, ns, grid_levels=None) -> list[tuple[str, int, int | None]]:
    """The rows of a study, ``(strategy, n, levels)`` (``levels`` None but for grids), in
    the order they are measured: strategy by strategy, N increasing."""
    ns = sorted({int(n) for n in ns})
    if not ns or ns[0] < 1:
        raise InputError(f"every N must be >= 1, got {ns}")
    rows = []
    for s in strategies:
        if s == "grid":
            rows += [("grid", n, lv) for lv, n in grid_levels_for(robot, ns, grid_levels).items()]
        else:
            rows += [(s, n, None) for n in ns]
    return rows


def heldout_set(body, n: int, seed: int) -> tuple[np.ndarray, np.ndarray, str]:
    """The common held-out set: ``n`` random allowed commands (n, m) rad (seeded by ``seed``),
    their noise-free settled tips (n, 3) m, and a short fingerprint of the commands."""
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
    """A forward model u (N, m) rad -> y (N, 3) m. ``"mlp"`` by ``"lm"``: ``lab``'s network
    trained by LM with the paper's stopping rules on a 90/10 train/validation split (all for
    training below 10 samples), as the transfer curve's ``real-only``; anything else goes to
    :func:`lab.learn.models.fit_model` (e.g. ``algorithm="br"``: Bayesian regularisation,
    no validation set; models ensemble, gpr, knn, sklearn-mlp)."""
    if name == "mlp" and algorithm == "lm":
        from lab.learn.train import train

        ratios = (0.9, 0.1, 0.0) if len(u) >= 10 else (1.0, 0.0, 0.0)
        return train(u, y, tuple(hidden), ratios=ratios, seed=seed, epochs=epochs).model
    try:
        from lab.learn.models import fit_model
    except ImportError:
        raise InputError(f"model {name!r} by {algorithm!r} needs lab.learn.models, which is missing") from None
    return fit_model(name, u, y, hidden=tuple(hidden), seed=seed, epochs=epochs, algorithm=algorithm)


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
        from lab.learn.active import active_sampling

        u, y, _ = active_sampling(
            robot,
            measure,
            n,
            min(int(opts["batch"]), n),
            n_initial=None if opts.get("n_initial") is None else min(int(opts["n_initial"]), n),
            hidden=tuple(opts["hidden"]),
            seed=seed,
            epochs=opts["epochs"],
            fit_ensemble=_ensemble_fitter(opts),
        )
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
    """One row: ``strategy`` draws ``n`` commands (a grid: its ``levels``, whose safe count
    ``n`` is), the body's tips are measured, ``model`` is fitted and evaluated on ``heldout``
    = (u (H, m) rad, settled tips (H, 3) m, fingerprint). Errors in m, times in s, ``capture_h``
    in hours at ``samples_per_hour``; the shapes' errors are NaN without ``tracking``.
    ``algorithm`` trains the model (and the active sampler's ensemble); ``batch`` and
    ``n_initial`` (None: the sampler's default) are the active sampler's."""
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


def smallest_n(rows, metric: str, threshold: float) -> dict:
    """Per strategy, the smallest N whose ``metric`` (e.g. ``model_error_m`` <= 0.5e-3, or
    ``tracking_mean_m`` <= 1.5e-3) is at most ``threshold``, with that value: ``(n, value)``,
    or None if no N reaches it. Rows of several robots or seeds are averaged per N."""
    out = {}
    for s in dict.fromkeys(r["strategy"] for r in rows):
        per_n: dict[int, list] = {}
        for r in rows:
            if r["strategy"] == s and np.isfinite(float(r[metric])):
                per_n.setdefault(int(r["n"]), []).append(float(r[metric]))
        hit = [(n, float(np.mean(v))) for n, v in sorted(per_n.items()) if np.mean(v) <= threshold]
        out[s] = hit[0] if hit else None
    return out


def hours_saved(n: int, samples_per_hour: float, reference_n: int = PAPER_GRID_N) -> float:
    """Capture hours saved by capturing ``n`` samples instead of ``reference_n`` (the paper's
    7^3 grid) at ``samples_per_hour`` (negative: it costs more)."""
    return (reference_n - n) / samples_per_hour
