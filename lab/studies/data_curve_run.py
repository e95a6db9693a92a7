"""The ``data-curve`` run: the rows of a :class:`~lab.studies.data_curve_spec.DataCurveSpec`, resumed.

:func:`run_data_curve` measures every (strategy, N, seed) row of a study that its results
CSV does not hold yet (:func:`lab.studies.data_curve.data_curve_row`), one row per worker
process, and appends each as it comes: the CSV and its JSON sidecar are rewritten
atomically after every row, so an interrupted run resumes where it stopped. A file is only
resumed with the settings it was made with (robot, rig, model, mesh, held-out set, ...);
a sidecar or row that cannot be read is refused naming the file. :func:`read_data_curve`
reads the rows back with their numbers.
"""

from __future__ import annotations

import json
from pathlib import Path

from lab.errors import InputError
from lab.files import read_resumable_rows
from lab.specs import positive_int
from lab.studies.data_curve_spec import DataCurveSpec

__all__ = ["COLUMNS", "SETTINGS", "read_data_curve", "run_data_curve", "measure_row"]

COLUMNS = (
    "robot", "rig", "rig_spec", "strategy", "n", "grid_levels", "seed", "model", "model_error_m", "circle_m",
    "square_m", "rose_m", "tracking_mean_m", "fit_s", "design_s", "capture_h", "heldout_id",
)  # fmt: skip
#: What a file is resumed with only if it was made with the same.
SETTINGS = ("robot", "rig", "model", "hidden", "epochs", "heldout_seed", "heldout", "n_rings", "n_axial", "batch",
            "tracking", "n_points", "samples_per_hour", "algorithm", "n_initial")  # fmt: skip
#: The value of a setting added later, in files made before it.
SETTING_DEFAULTS = {"algorithm": "lm", "n_initial": None}
_TEXT = ("robot", "rig", "rig_spec", "strategy", "model", "heldout_id")


def _number(path: Path, line: int, column: str, value):
    """A row's value as its type (int ``n``/``seed``, int or None ``grid_levels``, else float)."""
    try:
        if column in ("n", "seed"):
            return int(value)
        if column == "grid_levels":
            return int(value) if value else None
        return float(value)
    except (TypeError, ValueError):
        raise InputError(
            f"{path}: line {line}: {column} {value!r} is not a number; repair the file or choose another output file"
        ) from None


def _read(path: Path) -> tuple[list[dict], dict]:
    """The rows of ``path`` as written (strings, checked to parse) and its sidecar ({} if none)."""
    if not path.exists():
        return [], {}
    rows = read_resumable_rows(path, COLUMNS, "data-curve")
    for i, r in enumerate(rows):
        for c in COLUMNS:
            if c not in _TEXT:
                _number(path, i + 2, c, r[c])
    side = Path(f"{path}.json")
    if not side.exists():
        return rows, {}
    try:
        meta = json.loads(side.read_text())
    except ValueError as err:
        raise InputError(
            f"{side}: the sidecar of {path} is not valid JSON ({err}); choose another output file"
        ) from None
    if not isinstance(meta, dict) or not isinstance(meta.get("settings", {}), dict | None):
        raise InputError(
            f"{side}: the sidecar of {path} must be a JSON object with settings; choose another output file"
        )
    if not isinstance(meta.get("commands", []), list):
        raise InputError(f"{side}: the sidecar's commands must be a list; choose another output file")
    return rows, meta


def read_data_curve(path) -> list[dict]:
    """Rows of a ``data-curve`` CSV; numbers as floats (``n`` and ``seed`` as int, ``grid_levels`` int or None)."""
    path = Path(path)
    rows, _ = _read(path)
    for i, r in enumerate(rows):
        for k, v in r.items():
            if k not in _TEXT:
                r[k] = _number(path, i + 2, k, v)
    return rows


def _write(path: Path, rows: list[dict], meta: dict) -> None:
    from lab.files import atomic_write_group

    text = [",".join(COLUMNS)] + [",".join(str(r[c]) for c in COLUMNS) for r in rows]
    atomic_write_group({Path(f"{path}.json"): json.dumps(meta, indent=2) + "\n", path: "\n".join(text) + "\n"})


_BODIES: dict = {}


def _body(robot_spec: str, rig: str, n_rings, n_axial):
    """The robot's body, built once per process (its equilibrium cache is reused)."""
    from lab.description import load_robot
    from lab.studies.data_curve import make_body

    key = (robot_spec, rig, n_rings, n_axial)
    if key not in _BODIES:
        _BODIES[key] = make_body(load_robot(robot_spec), rig, n_rings=n_rings, n_axial=n_axial)
    return _BODIES[key]


def measure_row(spec: DataCurveSpec, heldout, plan: tuple, kw: dict) -> dict:
    """One row, ``plan`` = (strategy, n, levels, seed) (runs in this process or a worker)."""
    from lab.studies.data_curve import data_curve_row

    body, label, noise = _body(spec.robot, spec.rig, spec.mesh.n_rings, spec.mesh.n_axial)
    strategy, n, levels, seed = plan
    row = data_curve_row(body, strategy, n, levels, heldout=heldout, noise_sigma_m=noise, seed=seed, **kw)
    return {"robot": body.robot.name, "rig": label, "rig_spec": spec.rig, **row}


def _meta(spec: DataCurveSpec, old: dict, resumed: bool, rate: tuple, heldout_id: str, command: str) -> dict:
    from lab.files import code_version

    _, label, noise = _body(spec.robot, spec.rig, spec.mesh.n_rings, spec.mesh.n_axial)
    commands = old.get("commands", []) if resumed else []
    return {
        "kind": "lab.data_curve",
        "format_version": 1,
        "label": f"{label}: quasi-static settled tips"
        + (f", motion-capture noise {noise:g} m per axis on the samples" if noise else ", no noise"),
        "settings": spec.settings(rate[0]),
        "noise_sigma_m": noise,
        "samples_per_hour_source": rate[1],
        "heldout": {"n": spec.heldout, "seed": spec.heldout_seed, "id": heldout_id, "tips": "settled, no noise"},
        "model_recipe": "mlp: lab.learn.train, LM with the paper's stopping rules, 90/10 train/validation split"
        if spec.model == "mlp" and spec.algorithm == "lm"
        else f"lab.learn.models.fit_model({spec.model!r}, algorithm={spec.algorithm!r})",
        "command": command,
        "commands": commands + ([command] if command not in commands else []),
        "code_version": code_version(),
        "units": {"*_m": "m", "fit_s": "s", "design_s": "s", "capture_h": "h"},
    }


def run_data_curve(spec: DataCurveSpec, out, *, jobs: int = 1, command: str = "", log=None) -> list[dict]:
    """Measure the rows of ``spec`` not yet in the CSV ``out`` (read first, resumed),
    rewriting ``out`` and ``out.json`` after each row. InputError for a file made with other
    settings or unreadable.

    Parameters
    ----------
    spec : DataCurveSpec
        The study.
    out : str or Path
        The results CSV (its sidecar is ``out.json``).
    jobs : int, optional
        Worker processes (1: measure in this process).
    command : str, optional
        The command line recorded in the sidecar.
    log : callable, optional
        ``log(line)`` is told the plan and each row.

    Returns
    -------
    list of dict
        All rows of the file (the old ones as written, as strings; the new ones as measured),
        columns :data:`COLUMNS` (errors in m, times in s, ``capture_h`` in h).
    """
    from lab.description import load_robot
    from lab.studies.data_curve import heldout_set
    from lab.studies.data_curve_plan import plan_rows

    log = log or (lambda line: None)
    if positive_int(jobs):
        raise InputError(f"jobs (worker processes) must be a positive integer, got {jobs!r}")
    spec.check(load_robot(spec.robot))
    rate = spec.capture_rate()
    settings, out = spec.settings(rate[0]), Path(out)
    rows, old = _read(out)
    if rows and old.get("settings") is not None:
        was = {k: old["settings"].get(k, SETTING_DEFAULTS.get(k)) for k in SETTINGS}
        diff = [k for k in SETTINGS if json.dumps(was[k]) != json.dumps(settings[k])]
        if diff:
            raise InputError(f"{out} was made with other settings ({', '.join(diff)}); choose another output file")
    body, _, _ = _body(spec.robot, spec.rig, spec.mesh.n_rings, spec.mesh.n_axial)
    heldout = heldout_set(body, spec.heldout, spec.heldout_seed)
    if any(r["heldout_id"] != heldout[2] for r in rows):
        raise InputError(f"{out} was measured on another held-out set; choose another output file")
    have = {(r["strategy"], int(r["n"]), int(r["seed"])) for r in rows}
    plan = [
        (*p, seed)
        for seed in dict.fromkeys(spec.seeds)
        for p in plan_rows(body.robot, spec.strategies, spec.ns, spec.grid_levels)
        if (*p[:2], seed) not in have
    ]
    log(f"{len(plan)} rows to measure, {len(have)} already in {out}")
    meta = _meta(spec, old, bool(rows), rate, heldout[2], command)
    kw = spec.row_options(rate[0])
    if jobs == 1 or len(plan) <= 1:
        _collect((measure_row(spec, heldout, p, kw) for p in plan), rows, out, meta, log)
        return rows
    from joblib import Parallel, delayed

    from lab.workers import worker_config

    with worker_config():
        runner = Parallel(n_jobs=min(jobs, len(plan)), return_as="generator_unordered")
        _collect(runner(delayed(measure_row)(spec, heldout, p, kw) for p in plan), rows, out, meta, log)
    return rows


def _collect(results, rows: list[dict], out: Path, meta: dict, log) -> None:
    for row in results:
        rows.append(row)
        _write(out, rows, meta)
        nan = row["tracking_mean_m"] != row["tracking_mean_m"]
        track = "" if nan else f", tracking {100 * row['tracking_mean_m']:.3f} cm"
        log(f"{row['strategy']} N={row['n']}: model error {1000 * row['model_error_m']:.3f} mm{track} -> {out}")
    if not rows or not out.exists():
        _write(out, rows, meta)
