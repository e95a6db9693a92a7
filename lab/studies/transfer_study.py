"""The sim-to-real curve: how many real samples close the gap, by which transfer method.

For one emulated as-built robot (:class:`lab.rig.twin.AsBuiltBody`), :func:`curve_rows`
measures for each transfer method and number N of real samples the **model error** (mean
distance in m between prediction and settled tip on held-out commands drawn uniformly from
the safe set) and the Table I **tracking error** per shape (m; followed open loop through
the model, IK by bounded LM as ``track``). The robot answers with its quasi-static map
(:meth:`AsBuiltBody.quasi_static_tip`: the tip settled after the capture protocol's reset),
plus its own motion-capture noise on the real samples, so a family of robots x methods x N
fits in minutes. The real samples are the first N of one space-filling order of the safe
commands, so each N's set contains the smaller ones. The design and its measurements:
``docs/design/studies.md``.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from lab.control.ik import IKSolver
from lab.control.trajectories import builtin
from lab.errors import InputError
from lab.rig.twin import quasi_static_tips  # noqa: F401 (part of this module's API)

__all__ = [
    "SHAPES", "METHOD_MIN_N", "random_safe_commands", "quasi_static_tips", "evaluate_model", "curve_rows",
    "expected_pairs", "make_methods", "read_curve", "family_table1", "robot_order", "findings", "smallest_n",
    "defect_variants"
]  # fmt: skip

SHAPES = ("circle", "square", "rose")


def random_safe_commands(robot, n: int, seed: int = 0) -> np.ndarray:
    """Commands drawn uniformly from the robot's safe set, for held-out tests: almost surely
    not lattice points (:func:`lab.data.designs.random_commands`).

    Parameters
    ----------
    robot : RobotDescription
        The robot.
    n, seed : int
        Number of commands and their seed.

    Returns
    -------
    numpy.ndarray, shape (n, n_cables)
        Motor commands (rad).
    """
    from lab.data.designs import random_commands

    return random_commands(robot, n, seed)


def evaluate_model(model, body, u_test, tips_test, n_points: int | None = 24, shapes=SHAPES) -> dict:
    """Model error on held-out commands and the Table I tracking error per shape, in metres.

    Parameters
    ----------
    model : forward model
        Has ``predict(u)`` (N, 3) m (and what :meth:`IKSolver.for_model` needs).
    body : AsBuiltBody or NominalBody
        The robot the IK's commands are played on (its quasi-static map).
    u_test, tips_test : numpy.ndarray, shapes (H, m), (H, 3)
        Held-out commands (rad) and their true tips (m).
    n_points : int or None, optional
        Targets per shape (None: each path's default).
    shapes : sequence of str, optional
        Built-in trajectories of :func:`lab.control.trajectories.builtin` (default Table I's;
        the six-cable arm's :data:`lab.control.trajectories.SIX_CABLE`).

    Returns
    -------
    dict
        ``model_error_m``; per shape ``{shape}_m``, ``{shape}_size_ratio`` (RMS spread about the
        centroid, reached over target) and centroid shift ``{shape}_shift_m`` (3,) m; their means
        ``tracking_mean_m``, ``size_ratio_mean``, ``shift_mean_m``.
    """
    row = {"model_error_m": float(np.mean(np.linalg.norm(model.predict(u_test) - tips_test, axis=1)))}
    solver = IKSolver.for_model(model, body.robot)
    for shape in shapes:
        targets = builtin(shape, n_points)
        plan = solver.follow(targets)
        reached = quasi_static_tips(body, plan.u_motor)
        row[f"{shape}_m"] = float(np.mean(np.linalg.norm(reached - targets, axis=1)))
        # the paper's second finding: sim-data trajectories come out smaller and shifted
        c_t, c_r = targets.mean(axis=0), reached.mean(axis=0)
        spread = np.sqrt(np.mean(np.sum((targets - c_t) ** 2, axis=1)))
        row[f"{shape}_size_ratio"] = float(np.sqrt(np.mean(np.sum((reached - c_r) ** 2, axis=1))) / spread)
        row[f"{shape}_shift_m"] = [float(v) for v in c_r - c_t]
    row["tracking_mean_m"] = float(np.mean([row[f"{s}_m"] for s in shapes]))
    row["size_ratio_mean"] = float(np.mean([row[f"{s}_size_ratio"] for s in shapes]))
    row["shift_mean_m"] = [float(v) for v in np.mean([row[f"{s}_shift_m"] for s in shapes], axis=0)]
    return row


def curve_rows(
    body,
    methods: dict[str, Callable],
    ns,
    u_pool,
    *,
    u_test,
    noise_sigma_m: float,
    seed: int = 0,
    n_points: int = 24,
    label: str = "",
    on_row: Callable | None = None,
    skip=frozenset(),
) -> list[dict]:
    """One row per (method, N); ``on_row(row)`` is called after each row (e.g. to append it
    to a results file).

    Parameters
    ----------
    body : AsBuiltBody
        The emulated robot.
    methods : dict
        ``{name: make(u_real, y_real) -> model or None}`` (:func:`make_methods`; N = 0: the
        simulation network itself, where the method allows).
    ns : iterable of int
        Numbers of real samples N.
    u_pool, u_test : numpy.ndarray, shapes (P, m), (H, m)
        The space-filling order (rad) the first N samples are taken from; held-out commands (rad).
    noise_sigma_m, seed : float, int
        Motion-capture noise on the real samples (m per axis) and its seed.
    n_points, label : int, str, optional
        Targets per Table I shape; the rows' ``robot``.
    on_row, skip : callable, set of tuple, optional
        Called with each row; (method, N) pairs measured before, not measured again.

    Returns
    -------
    list of dict
        ``robot, method, n_real, fit_s`` (s) and :func:`evaluate_model`'s errors (m).
    """
    ns = sorted(int(n) for n in ns)
    if ns and ns[-1] > len(u_pool):
        raise InputError(f"N = {ns[-1]} real samples asked for, but the pool has {len(u_pool)} commands")
    y_pool = quasi_static_tips(body, u_pool[: max(ns, default=0)], noise_sigma_m, seed)
    tips_test = quasi_static_tips(body, u_test)
    rows = []
    for name, make in methods.items():
        for n in ns:
            if (name, n) in skip:
                continue
            t0 = time.perf_counter()
            model = make(u_pool[:n], y_pool[:n])
            if model is None:  # this method cannot work from n samples
                continue
            t_fit = time.perf_counter() - t0
            row = {"robot": label, "method": name, "n_real": n, "fit_s": t_fit}
            row.update(evaluate_model(model, body, u_test, tips_test, n_points))
            rows.append(row)
            if on_row is not None:
                on_row(row)
    return rows


#: The methods of the curve, and the fewest real samples each works from.
METHOD_MIN_N = {"sim-only": 0, "real-only": 2, "finetune-last": 2, "finetune": 2, "residual": 1, "calibrated": 5}


def expected_pairs(methods, ns) -> set:
    """The (method, N) rows a curve run produces: ``sim-only`` at N = 0 only, every other
    method from its :data:`METHOD_MIN_N` on (and never at N = 0)."""
    return {
        (m, int(n))
        for m in methods
        for n in ns
        if (n == 0 if m == "sim-only" else int(n) >= max(1, METHOD_MIN_N.get(m, 1)))
    }


def make_methods(sim_model, names, hidden=(20, 20), seed: int = 0, extra: dict | None = None) -> dict:
    """Model builders for the ``names`` of :data:`METHOD_MIN_N`: ``sim-only`` is the
    simulation network at N = 0 only; the others use :func:`lab.transfer.data_methods.transfer_model`
    from their minimum N on.

    Parameters
    ----------
    sim_model, names : MLP, sequence of str
        The network trained on simulated data; the methods (InputError for an unknown one).
    hidden, seed : tuple of int, int, optional
        Hidden widths and seed of the networks trained on real samples.
    extra : dict, optional
        Further ``{name: builder}`` (e.g. the calibrated physics).

    Returns
    -------
    dict
        ``{name: make(u_real, y_real) -> model or None}``.
    """
    from lab.transfer.data_methods import transfer_model

    def builder(name):
        if name == "sim-only":
            return lambda u, y: sim_model if len(u) == 0 else None

        def make(u, y):
            if len(u) < METHOD_MIN_N[name]:
                return None
            return transfer_model(name, u, y, sim_model, hidden=hidden, seed=seed)

        return make

    unknown = [n for n in names if n not in METHOD_MIN_N and n not in (extra or {})]
    if unknown:
        raise InputError(f"unknown method(s) {unknown}; known: {[*METHOD_MIN_N, *(extra or {})]}")
    return {n: (extra[n] if extra and n in extra else builder(n)) for n in names}


def read_curve(path) -> list[dict]:
    """Rows of a ``transfer-curve`` CSV.

    Parameters
    ----------
    path : str or Path
        The CSV.

    Returns
    -------
    list of dict
        Numbers as floats (m, s), ``n_real`` as int, ``robot`` and ``method`` as str.
    """
    import csv

    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    for r in rows:
        for k, v in r.items():
            if k not in ("robot", "method"):
                r[k] = int(v) if k == "n_real" else float(v)
    return rows


def family_table1(rows: list[dict], real_n: int = 308) -> list[dict]:
    """Table I over the family, in cm: for the conditions "Real Data + Real Robot" (the
    3-20-20-3 trained on ``real_n`` real samples, ``real-only``) and "Sim Data + Real Robot"
    (``sim-only``), per shape the mean and standard deviation over the random robots, the
    shipped robot's value (if measured) and the paper's.

    Parameters
    ----------
    rows, real_n : list of dict, int
        Rows of a transfer curve (:func:`read_curve`); N of the real-data condition.

    Returns
    -------
    list of dict
        One per condition: ``condition``, ``n_robots``, per shape ``{shape}_mean_cm``,
        ``_std_cm``, ``_shipped_cm``, ``_paper_cm`` (NaN where not measured).
    """
    from lab.studies.table1 import PAPER_CM

    pick = {"Real Data + Real Robot": ("real-only", real_n), "Sim Data + Real Robot": ("sim-only", 0)}
    out = []
    for cond, (method, n) in pick.items():
        sel = [r for r in rows if r["method"] == method and r["n_real"] == n]
        fam = [r for r in sel if r["robot"] != "shipped"]
        shipped = next((r for r in sel if r["robot"] == "shipped"), None)
        row = {"condition": cond, "n_robots": len(fam)}
        for s in SHAPES:
            v = 100 * np.array([r[f"{s}_m"] for r in fam])
            row[f"{s}_mean_cm"] = float(v.mean()) if len(v) else float("nan")
            row[f"{s}_std_cm"] = float(v.std(ddof=1)) if len(v) > 1 else float("nan")
            row[f"{s}_shipped_cm"] = 100 * shipped[f"{s}_m"] if shipped else float("nan")
            row[f"{s}_paper_cm"] = PAPER_CM[cond][s]
        out.append(row)
    return out


def robot_order(label: str) -> tuple:
    """Sort key of robot labels: ``shipped`` first, then ``KIND:SEED`` (``random:3``,
    ``foam:12``) by kind and SEED, then others."""
    if label == "shipped":
        return (0, "", 0, label)
    kind, _, seed = label.partition(":")
    return (1, kind, int(seed), label) if seed.isdigit() else (2, "", 0, label)


def findings(rows: list[dict], real_n: int = 308, factor: float = 2.0) -> list[dict]:
    """Per robot: the paper's two findings, tested. ``gap_ratio`` = sim-data over real-data
    tracking error (finding 1 holds if >= ``factor``); ``size_ratio`` of the sim-data
    trajectories and their centroid shift (m) against the real-data ones (finding 2 holds if
    they come out smaller -- ``smaller`` -- and further off-centre -- ``shifted``; each part
    is reported too, since a softer arm than modelled moves *more*).

    Parameters
    ----------
    rows, real_n : list of dict, int
        Rows of a transfer curve (:func:`read_curve`); N of the real-data condition.
    factor : float, optional
        Gap ratio that finding 1 needs.

    Returns
    -------
    list of dict
        One per robot with both conditions, in the order shipped, random:0, random:1, ...
    """
    out = []
    for robot in sorted(dict.fromkeys(r["robot"] for r in rows), key=robot_order):
        sim = next((r for r in rows if r["robot"] == robot and r["method"] == "sim-only"), None)
        real = next(
            (r for r in rows if r["robot"] == robot and r["method"] == "real-only" and r["n_real"] == real_n), None
        )
        if sim is None or real is None:
            continue
        shift = lambda r: float(np.linalg.norm([r["shift_x_m"], r["shift_y_m"], r["shift_z_m"]]))  # noqa: E731
        ratio = sim["tracking_mean_m"] / real["tracking_mean_m"]
        out.append(
            {
                "robot": robot,
                "gap_ratio": ratio,
                "finding_1": bool(ratio >= factor),
                "sim_size_ratio": sim["size_ratio_mean"],
                "sim_shift_m": shift(sim),
                "sim_shift_z_m": sim["shift_z_m"],
                "real_shift_m": shift(real),
                "smaller": bool(sim["size_ratio_mean"] < 1.0),
                "shifted": bool(shift(sim) > shift(real)),
                "finding_2": bool(sim["size_ratio_mean"] < 1.0 and shift(sim) > shift(real)),
            }
        )
    return out


def smallest_n(rows: list[dict], threshold_m: float, metric: str = "tracking_mean_m") -> dict:
    """Per method: the smallest N whose family-mean ``metric`` is at most ``threshold_m``.

    Parameters
    ----------
    rows : list of dict
        Rows of a transfer curve (the shipped robot's are left out).
    threshold_m, metric : float, str
        The threshold (m) and the column compared.

    Returns
    -------
    dict
        ``{method: (N, mean) or None}`` (None if no N reaches it).
    """
    out = {}
    for method in dict.fromkeys(r["method"] for r in rows):
        means = {}
        for r in rows:
            if r["method"] == method and r["robot"] != "shipped":
                means.setdefault(r["n_real"], []).append(r[metric])
        hit = [(n, float(np.mean(v))) for n, v in sorted(means.items()) if np.mean(v) <= threshold_m]
        out[method] = hit[0] if hit else None
    return out


def defect_variants(defects, robot) -> dict:
    """The as-built ``defects`` taken apart, to trace the sim-to-real bias to its causes:
    each variant has only that geometric defect (softness, stiffness gradient, eyelet shifts,
    cable slack; "all": every one) and no friction play, so that each is a quasi-static map.

    Parameters
    ----------
    defects, robot : Defects, RobotDescription
        The as-built defects (with their ``source``) and the nominal robot.

    Returns
    -------
    dict
        ``{"softer", "gradient", "eyelets", "slack", "all"}`` -> :class:`lab.asbuilt.arm.Defects`.
    """
    import copy

    from lab.asbuilt.arm import parse_defects

    def only(material=None, eyelets=False, slack=False):
        d = copy.deepcopy(defects.source)
        if material is None:
            d["material"].update(softness=1.0, gradient=0.0)
        elif material == "softness":
            d["material"]["gradient"] = 0.0
        elif material == "gradient":
            d["material"]["softness"] = 1.0
        for c in d["cables"]:
            c["play_m"] = 0.0
            if not eyelets:
                c["via_shift_m"] = [0.0, 0.0, 0.0]
            if not slack:
                c["slack_m"] = 0.0
        return parse_defects(d, robot)

    return {
        "softer": only(material="softness"),
        "gradient": only(material="gradient"),
        "eyelets": only(eyelets=True),
        "slack": only(slack=True),
        "all": only(material="all", eyelets=True, slack=True),
    }
