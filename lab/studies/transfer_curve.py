"""The ``transfer-curve`` run: the sim-to-real curve over a family of emulated as-built robots.

:class:`TransferCurveSpec` holds its settings (robots, methods, numbers of real samples,
design, test sizes, meshes, workers). :func:`transfer_curve_run` measures, per robot
(members 0..K-1 of :data:`lab.asbuilt.RANDOM`, or with ``family_kind="foam"`` of
:data:`lab.asbuilt.FOAM`, and the shipped defects), method and N, the rows
of :func:`lab.studies.transfer_study.curve_rows`, one robot per worker.
Rows are appended robot by robot (the CSV and its JSON sidecar are rewritten atomically
each time), so an interrupted run resumes where it stopped; a robot whose rows are all
there is skipped, and a method added later measures only its own rows.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

from lab.errors import InputError
from lab.fem.bodies.mesh import check_mesh_size
from lab.fem.bodies.mesh_spec import MeshSpec
from lab.files import read_resumable_rows
from lab.specs import Spec, non_negative_int, option, positive_int

__all__ = ["COLUMNS", "DEFAULT_NS", "TransferCurveSpec", "study_robot", "transfer_curve_run"]

DEFAULT_NS = (0, 5, 10, 20, 30, 50, 100, 308)
DEFAULT_METHODS = ("sim-only", "real-only", "finetune-last", "finetune", "residual")
COLUMNS = (
    "robot", "method", "n_real", "fit_s", "model_error_m", "circle_m", "square_m", "rose_m", "tracking_mean_m",
    "circle_size_ratio", "square_size_ratio", "rose_size_ratio", "size_ratio_mean", "shift_x_m", "shift_y_m",
    "shift_z_m",
)  # fmt: skip


def _methods(v) -> str | None:
    from lab.studies.transfer_study import METHOD_MIN_N

    return None if len(v) and all(m in METHOD_MIN_N for m in v) else f"must be among {', '.join(METHOD_MIN_N)}"


def _counts(v) -> str | None:
    return None if len(v) and all(non_negative_int(n) is None for n in v) else "must be integers >= 0"


def _at_least_2(v) -> str | None:
    return None if positive_int(v) is None and v >= 2 else "must be an integer >= 2"


def _mesh(spec) -> dict:
    return {"n_rings": spec.mesh.n_rings, "n_axial": spec.mesh.n_axial}


@dataclass(frozen=True)
class TransferCurveSpec(Spec):
    """A transfer curve: which robots, methods and N, how they are measured.

    Attributes
    ----------
    sim_model : str
        Network trained on simulated data (.npz), required.
    robot : str
        Robot name or description TOML.
    family : int
        Family members 0..K-1.
    family_kind : str
        ``random`` (twin:random:K, in the calibrator's model class) or ``foam`` (twin:foam:K,
        defects outside it).
    shipped : bool
        Also the robot of the shipped defects file.
    methods : tuple of str
        Transfer methods (:data:`lab.studies.transfer_study.METHOD_MIN_N`).
    ns : tuple of int
        Numbers of real samples N.
    design : str
        Which N commands: the first N of one ``random``, ``sobol`` or ``maximin`` design of
        ``max(ns)`` commands. These designs are prefix-stable, so every method's row at N uses
        the commands of a design of N (a Latin hypercube is not, and is not offered).
    n_test, n_points : int
        Held-out random commands per robot; targets per trajectory.
    seed : int
        Seed of designs, noise and training.
    calibration_mesh : tuple of (int, int) or None
        ``calibrated``: mesh (rings, axial) of calibration and re-simulation (None: the robot's).
    sim_levels : int
        ``calibrated``: re-simulate the safe points of this lattice (levels per motor).
    jobs : int
        Worker processes, one robot each.
    mesh : MeshSpec
        The emulated robots' FEM mesh.
    """

    sim_model: str = option(None, required=True, help="network trained on simulated data (.npz)")
    robot: str = option("three-cable", help="robot name or description TOML")
    family: int = option(10, type=int, check=non_negative_int, help="family members 0..K-1")
    family_kind: str = option(
        "random",
        choices=("random", "foam"),
        help="which family: random (twin:random:K, in the calibrator's model class) or foam (twin:foam:K, "
        "defects outside it)",
    )
    shipped: bool = option(False, help="also the robot of the shipped defects file")
    methods: tuple[str, ...] = option(
        DEFAULT_METHODS,
        check=_methods,
        help="transfer methods: sim-only, real-only, finetune-last, finetune, residual, calibrated (the last "
        "is slow: a calibration and a re-simulation of the lattice per N)",
    )
    ns: tuple[int, ...] = option(DEFAULT_NS, type=int, check=_counts, help="numbers of real samples")
    design: str = option("maximin", choices=("random", "sobol", "maximin"), help="which N commands")
    n_test: int = option(100, type=int, check=positive_int, help="held-out random commands per robot")
    n_points: int = option(24, type=int, check=_at_least_2, help="targets per trajectory")
    seed: int = option(0, type=int, check=non_negative_int, help="seed of designs, noise and training")
    calibration_mesh: tuple[int, int] | None = option(
        None,
        type=int,
        help="calibrated: mesh of calibration and re-simulation (default: the robot's)",
    )
    sim_levels: int = option(
        7, type=int, check=positive_int, help="calibrated: re-simulate the safe points of this lattice"
    )
    jobs: int = option(1, type=int, check=positive_int, help="worker processes, one robot each")
    mesh: MeshSpec = field(default_factory=MeshSpec)

    def __post_init__(self):
        super().__post_init__()
        if self.calibration_mesh is not None:
            check_mesh_size(*self.calibration_mesh)

    def labels(self) -> list[str]:
        """The robots of the curve: "shipped" (if asked for), then "KIND:0".."KIND:K-1" (KIND the
        ``family_kind``, "random" or "foam").

        Returns
        -------
        list of str
            The robot labels, in that order.
        """
        return (["shipped"] if self.shipped else []) + [f"{self.family_kind}:{k}" for k in range(self.family)]

    def settings(self) -> dict:
        """The settings the results file's sidecar records (and that the rows depend on).

        Returns
        -------
        dict
            JSON-ready: ``family_kind, seed, ns, design, n_test, n_points, methods``, the mesh's
            ``n_rings``/``n_axial``, ``calibration_mesh`` and ``sim_levels``.
        """
        keys = ("family_kind", "seed", "ns", "design", "n_test", "n_points", "methods")
        d = {k: getattr(self, k) for k in keys}
        d.update(_mesh(self))
        d.update({"calibration_mesh": self.calibration_mesh, "sim_levels": self.sim_levels})
        return {k: list(v) if isinstance(v, tuple) else v for k, v in d.items()}


def study_robot(spec: TransferCurveSpec, label: str, skip=frozenset()) -> list[dict]:
    """The rows of robot ``label`` but the (method, N) pairs in ``skip`` (runs in a worker process)."""
    from lab.asbuilt.family import family_member
    from lab.data import design_commands
    from lab.description import load_robot
    from lab.learn.mlp import load_model
    from lab.rig.twin import AsBuiltBody
    from lab.studies.transfer_study import curve_rows, make_methods, random_safe_commands
    from lab.workers import watch_parent

    watch_parent()
    robot = load_robot(spec.robot)
    mesh = _mesh(spec)
    defects = family_member(robot, label, **mesh)  # drawn for the mesh it runs on
    body = AsBuiltBody(robot, defects, **mesh)
    sim_model = load_model(spec.sim_model)
    pool = design_commands(robot, max(max(spec.ns), 1), spec.design, spec.seed)
    u_test = random_safe_commands(robot, spec.n_test, spec.seed + 1)
    extra = {"calibrated": _calibrated_builder(robot, spec)} if "calibrated" in spec.methods else None
    methods = make_methods(sim_model, list(spec.methods), seed=spec.seed, extra=extra)
    rows = curve_rows(body, methods, list(spec.ns), pool, u_test=u_test, noise_sigma_m=defects.noise_sigma_m,
                      seed=spec.seed, n_points=spec.n_points, label=label, skip=skip)  # fmt: skip
    for r in rows:
        r["shift_x_m"], r["shift_y_m"], r["shift_z_m"] = r.pop("shift_mean_m")
        for s in ("circle", "square", "rose"):
            r.pop(f"{s}_shift_m", None)
    return rows


def _calibrated_builder(robot, spec: TransferCurveSpec):
    """``(u_real, y_real) -> model``: calibrated physics from 5 samples on; it re-simulates the
    safe points of the ``sim_levels`` lattice (the simulated dataset's commands)."""
    from lab.data.designs import grid_commands
    from lab.studies.transfer_study import METHOD_MIN_N
    from lab.transfer.calibrated import calibrated_model

    u_sim = grid_commands(robot, spec.sim_levels)
    u_sim = u_sim[robot.is_safe(u_sim)]
    rings, axial = spec.calibration_mesh or (robot.n_rings, robot.n_axial)

    def make(u, y):
        if len(u) < METHOD_MIN_N["calibrated"]:
            return None
        return calibrated_model(robot, u, y, u_sim, seed=spec.seed, n_rings=rings, n_axial=axial)

    return make


#: What a file is resumed with only if it was made with the same (sidecar key -> setting); the
#: robots (``family``, ``shipped``), ``methods`` and ``ns`` may grow from run to run.
RESUME_SETTINGS = {
    **{key: f"TransferCurveSpec.{key}" for key in ("robot", "sim_model", "family_kind", "seed", "design")},
    **{key: f"TransferCurveSpec.{key}" for key in ("n_test", "n_points")},
    "n_rings": "MeshSpec.n_rings", "n_axial": "MeshSpec.n_axial",
}  # fmt: skip
#: ... and, once the file holds calibrated rows, the settings those were measured with.
CALIBRATED_SETTINGS = {key: f"TransferCurveSpec.{key}" for key in ("calibration_mesh", "sim_levels")}
#: The value of a setting added later, in files made before it (other missing keys are not checked).
SETTING_DEFAULTS = {"family_kind": "random"}


def _read(path: Path) -> tuple[list[dict], dict]:
    """The rows of ``path`` (strings, each checked to parse) and its sidecar ({} if none)."""
    if not path.exists():
        return [], {}
    rows = read_resumable_rows(path, COLUMNS, "transfer-curve")
    for line, r in enumerate(rows, start=2):
        for c in COLUMNS[2:]:
            try:
                int(r[c]) if c == "n_real" else float(r[c])
            except ValueError:
                raise InputError(
                    f"{path}: line {line}: {c} {r[c]!r} is not a number; repair the file or choose another output file"
                ) from None
    side = Path(f"{path}.json")
    if not side.exists():
        return rows, {}
    try:
        meta = json.loads(side.read_text())
    except ValueError as err:
        raise InputError(
            f"{side}: the sidecar of {path} is not valid JSON ({err}); choose another output file"
        ) from None
    if not isinstance(meta, dict) or not isinstance(meta.get("commands", []), list):
        raise InputError(
            f"{side}: the sidecar of {path} must be a JSON object (commands a list); choose another output file"
        )
    return rows, meta


def _same_file(a, b) -> bool:
    try:
        return a == b or (a is not None and b is not None and Path(a).samefile(b))
    except OSError:
        return False


def _check_resume(spec: TransferCurveSpec, out: Path, rows: list[dict], old: dict) -> None:
    """Refuse to add rows to ``out`` measured with other settings than its own (its sidecar's)."""
    new = {"robot": spec.robot, "sim_model": spec.sim_model, **spec.settings()}
    names = {**RESUME_SETTINGS, **(CALIBRATED_SETTINGS if any(r["method"] == "calibrated" for r in rows) else {})}
    diff = []
    for key, name in names.items():
        if key not in old and key not in SETTING_DEFAULTS:  # a file from before the setting was recorded
            continue
        was = old.get(key, SETTING_DEFAULTS.get(key))
        same = _same_file(was, new[key]) if key == "sim_model" else json.dumps(was) == json.dumps(new[key])
        if not same:
            diff.append(f"{name} {was} (this run: {new[key]})")
    if rows and diff:
        raise InputError(
            f"{out} was made with {', '.join(diff)}; its rows would mix two studies: resume it with its own "
            "settings or choose another output file"
        )


def _check_model(spec: TransferCurveSpec) -> None:
    """Refuse a simulation network that does not map the robot's motors to a tip, and a mesh
    that would not fit in memory, before any worker starts."""
    from lab.description import load_robot
    from lab.learn.mlp import load_model

    robot = load_robot(spec.robot)
    spec.mesh.resolve(robot)
    model = load_model(spec.sim_model)
    if (model.n_u, model.n_y) != (robot.n_inputs, 3):
        raise spec.field_error(
            f"{spec.name_of('sim_model')} {spec.sim_model} maps {model.n_u} motor angles to {model.n_y} outputs, "
            f"but {spec.name_of('robot')} {robot.name} has {robot.n_inputs} motors and a 3-D tip",
            "sim_model",
            "robot",
        )


def _write_rows(path: Path, rows: list[dict], meta: dict) -> None:
    from lab.files import atomic_write_group

    text = [",".join(COLUMNS)]
    for r in rows:
        text.append(",".join(str(r[c]) for c in COLUMNS))
    atomic_write_group({Path(f"{path}.json"): json.dumps(meta, indent=2) + "\n", path: "\n".join(text) + "\n"})


def _commands(meta: dict, command: str) -> list[str]:
    """Every command that added rows to the file of sidecar ``meta``, oldest first (one file
    can hold several runs, e.g. the slow calibrated method added to a finished curve)."""
    old = meta.get("commands") or ([meta["command"]] if "command" in meta else [])
    return old + ([command] if command not in old else [])


def transfer_curve_run(spec: TransferCurveSpec, out, *, command: str = "", log=None) -> list[dict]:
    """Measure the rows of ``spec`` not yet in the CSV ``out`` (read first, resumed) on
    ``spec.jobs`` workers, rewriting ``out`` and ``out.json`` after each robot.

    Parameters
    ----------
    spec : TransferCurveSpec
        The curve.
    out : str or Path
        The results CSV (its sidecar is ``out.json``).
    command : str, optional
        The command line recorded in the sidecar.
    log : callable, optional
        ``log(line)`` is told the plan and each robot's rows.

    Returns
    -------
    list of dict
        All rows of the file (the old ones as written, as strings), columns :data:`COLUMNS`
        (errors and shifts in m, ``fit_s`` in s).
    """
    from joblib import Parallel, delayed

    from lab.files import code_version
    from lab.studies.transfer_study import expected_pairs
    from lab.workers import worker_config

    log = log or (lambda line: None)
    out = Path(out)
    _check_model(spec)
    rows, old = _read(out)
    _check_resume(spec, out, rows, old)
    labels = spec.labels()
    want = expected_pairs(spec.methods, spec.ns)
    have = {lab: {(r["method"], int(r["n_real"])) for r in rows if r["robot"] == lab} for lab in labels}
    todo = [lab for lab in labels if not want <= have[lab]]
    log(f"{len(labels)} robots, {len(labels) - len(todo)} already in {out}")
    meta = {
        "kind": "lab.transfer_curve",
        "format_version": 1,
        "label": "emulated as-built robots (quasi-static settled tips, motion-capture noise on the real samples)",
        "robot": spec.robot,
        "sim_model": spec.sim_model,
        **spec.settings(),
        "command": command,
        "commands": _commands(old, command),
        "code_version": code_version(),
        "units": {"*_m": "m", "fit_s": "s"},
    }
    with worker_config():
        runner = Parallel(n_jobs=min(spec.jobs, max(1, len(todo))), return_as="generator_unordered")
        for new in runner(delayed(study_robot)(spec, lab, frozenset(have[lab])) for lab in todo):
            rows.extend(new)
            _write_rows(out, rows, meta)
            log(f"{new[0]['robot'] if new else '?'}: {len(new)} rows -> {out}")
    return rows
