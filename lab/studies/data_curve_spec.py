"""The settings of a data curve: :class:`DataCurveSpec`, the typed form of ``data-curve``'s flags.

Which robot on which rig (``--robot``, ``--rig``, the FEM mesh), which rows (``--strategies``
x ``--ns`` x ``--seeds``, ``--grid-levels``), how each row fits and is judged (``--model``,
``--hidden``, ``--epochs``, ``--algorithm``, the held-out set, ``--n-points``,
``--no-tracking``, the active sampler's ``--batch``/``--n-initial``) and the capture rate
that turns N into hours. Each field is declared with :func:`lab.specs.option`, so the flags'
help and checks live here. Counts are bounded by what a run can hold or finish: N and the
held-out set by a design's limit (:data:`lab.data.designs.MAX_DESIGN_N`), the rows of a
study by :data:`MAX_ROWS`. :meth:`DataCurveSpec.check` refuses what does not fit the robot.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

from lab.data.design_spec import ACTIVE_POOL, MAX_GRID_CANDIDATES
from lab.data.designs import DESIGNS, MAX_DESIGN_N, MAX_MAXIMIN_N
from lab.errors import InputError
from lab.fem.bodies.mesh_spec import MeshSpec
from lab.learn.train import ALGORITHMS
from lab.rig.spec import RigSpec
from lab.specs import Spec, at_most, non_negative_int, option, positive, positive_int
from lab.studies.data_curve_plan import check_model, check_strategies

__all__ = ["DataCurveSpec", "DEFAULT_NS", "DEFAULT_RATE_FROM", "FALLBACK_SAMPLES_PER_HOUR", "MAX_ROWS", "MAX_SEEDS"]

DEFAULT_NS = (25, 50, 100, 200, 308)
#: The capture rate of the shipped dataset, in case its sidecar is not at hand: samples per
#: hour of robot time of ``capture --rig twin --grid 7`` (data/real_three_cable.csv.json).
FALLBACK_SAMPLES_PER_HOUR = 290.35
DEFAULT_RATE_FROM = "data/real_three_cable.csv"
#: Most seeds per study, and most rows (strategies x N x seeds): each row trains a model.
MAX_SEEDS = 1_000
MAX_ROWS = 10_000
#: Most targets per Table I trajectory.
MAX_POINTS = 10_000


def _ints(low: int, high: int | None = None, what: str = "integers"):
    def check(v) -> str | None:
        ok = len(v) > 0 and all(isinstance(x, int) and not isinstance(x, bool) and x >= low for x in v)
        if not ok:
            return f"must be {what} >= {low}"
        return None if high is None or max(v) <= high else f"must be at most {high}"

    return check


def _algorithm(v) -> str | None:
    return None if v in ALGORITHMS else f"must be one of {', '.join(ALGORITHMS)}"


def _at_least_2(v) -> str | None:
    return None if positive_int(v) is None and v >= 2 else "must be an integer >= 2"


def default_strategies() -> tuple[str, ...]:
    """Every strategy but ``active`` that this install has."""
    return tuple(s for s in ("grid", "sobol", "lhs", "maximin", "random") if s == "grid" or s in DESIGNS)


@dataclass(frozen=True)
class DataCurveSpec(Spec):
    """One data-curve study: see the module docstring and the flags' help for each field.

    Attributes
    ----------
    robot : str
        Robot name or description TOML.
    rig : str
        ``sim``, ``twin[:DEFECTS.toml]``, ``twin:random:SEED`` or ``twin:foam:SEED``.
    strategies : tuple of str
        Sampling strategies (None: every one but ``active`` this install has).
    ns, grid_levels : tuple of int
        Numbers of samples N; a grid's levels per motor (None: nearest each N).
    model, algorithm : str
        Forward model (``mlp``, ``ensemble``, ``gpr``, ``knn``, ``sklearn-mlp``) and its training
        (``lm``, ``br``, ``adam``, ``lbfgs``).
    hidden : tuple of int
        Hidden layer widths.
    epochs : int or None
        Maximum training epochs.
    heldout, heldout_seed : int
        Held-out random allowed commands, and their seed.
    seeds : tuple of int
        Seeds of designs, noise and training: a row per seed.
    batch, n_initial : int
        Active sampling: samples per batch, initial Sobol design (None: the sampler's default).
    n_points : int
        Targets per Table I trajectory.
    tracking : bool
        Track Table I's shapes (False: the model error only).
    samples_per_hour : float or None
        Capture rate that turns N into hours (None: read from ``rate_from``).
    rate_from : str
        Dataset whose sidecar's ``capture.rate_samples_per_hour`` is used.
    mesh : MeshSpec
        The FEM mesh of the robot's body.
    """

    robot: str = option("three-cable", help="robot name or description TOML")
    rig: str = option("sim", help="sim | twin[:DEFECTS.toml] | twin:random:SEED | twin:foam:SEED")
    strategies: tuple[str, ...] | None = option(None, help="grid sobol lhs maximin random active")
    ns: tuple[int, ...] = option(DEFAULT_NS, type=int, check=_ints(1, MAX_DESIGN_N), help="numbers of samples N")
    grid_levels: tuple[int, ...] | None = option(None, type=int, check=_ints(2), help="grid: these levels per motor")
    model: str = option("mlp", help="mlp, ensemble, gpr, knn, sklearn-mlp")
    hidden: tuple[int, ...] = option((20, 20), type=int, check=_ints(1, what="widths"), help="hidden layer widths")
    epochs: int | None = option(None, type=int, check=positive_int, help="maximum training epochs")
    algorithm: str = option(
        "lm", check=_algorithm, help="training: lm (the paper's stopping rules), br (Bayesian), adam, lbfgs"
    )
    heldout: int = option(
        200, type=int, check=at_most(MAX_DESIGN_N, positive_int), help="held-out random allowed commands"
    )
    seeds: tuple[int, ...] = option(
        (0,), type=int, check=_ints(0), help="seeds of designs, noise and training: a row per seed"
    )
    heldout_seed: int = option(1, type=int, check=non_negative_int, help="seed of the held-out commands")
    batch: int = option(25, type=int, check=positive_int, help="active: samples per batch")
    n_initial: int | None = option(None, type=int, check=positive_int, help="active: initial Sobol design")
    n_points: int = option(24, type=int, check=at_most(MAX_POINTS, _at_least_2), help="targets per trajectory")
    tracking: bool = option(True, help="model error only (no Table I tracking)")
    samples_per_hour: float | None = option(None, type=float, check=positive, help="capture rate for capture_h")
    rate_from: str = option(DEFAULT_RATE_FROM, help="dataset whose sidecar's capture.rate_samples_per_hour is used")
    mesh: MeshSpec = field(default_factory=MeshSpec)

    def __post_init__(self):
        super().__post_init__()
        for name in ("strategies", "ns", "grid_levels", "hidden", "seeds"):
            if getattr(self, name) is not None:
                object.__setattr__(self, name, tuple(getattr(self, name)))
        strategies = default_strategies() if self.strategies is None else self.strategies
        object.__setattr__(self, "strategies", tuple(check_strategies(strategies)))
        check_model(self.model)
        if not isinstance(self.mesh, MeshSpec):
            raise InputError(f"mesh must be a MeshSpec, got {self.mesh!r}")
        if self.rig_spec.kind not in ("sim", "twin"):
            raise InputError(
                f"rig {self.rig!r}: the data curve measures through a body's quasi-static map; "
                "expected sim, twin, twin:DEFECTS.toml, twin:random:SEED or twin:foam:SEED"
            )
        name = self.name_of
        if "maximin" in self.strategies and max(self.ns) > MAX_MAXIMIN_N:
            raise self.field_error(
                f"{name('ns')}: a maximin design takes at most {MAX_MAXIMIN_N} commands, got N = {max(self.ns)}",
                "ns",
            )
        if "active" in self.strategies and min(self.batch, max(self.ns)) > ACTIVE_POOL:
            raise self.field_error(
                f"{name('batch')} must be at most {ACTIVE_POOL} (the candidates scored per batch), got {self.batch}",
                "batch",
            )
        n_seeds = len(set(self.seeds))
        if n_seeds > MAX_SEEDS:
            raise self.field_error(f"{name('seeds')}: at most {MAX_SEEDS} seeds per study, got {n_seeds}", "seeds")
        n_rows = len(self.strategies) * len(set(self.ns)) * n_seeds
        if n_rows > MAX_ROWS:
            raise self.field_error(
                f"{name('strategies')} x {name('ns')} x {name('seeds')}: {n_rows:,} rows, each a trained model; "
                f"at most {MAX_ROWS:,} per study (split it into several output files)",
                "strategies",
                "ns",
                "seeds",
            )

    @property
    def rig_spec(self) -> RigSpec:
        """The rig ``--rig`` names, on this study's mesh."""
        return RigSpec.parse(self.rig, mesh=self.mesh)

    def check(self, robot) -> None:
        """Refuse (InputError) what does not fit ``robot``: a mesh that would not fit in memory,
        a ``--grid-levels`` grid over :data:`lab.data.design_spec.MAX_GRID_CANDIDATES` commands.

        Parameters
        ----------
        robot : RobotDescription
            The study's robot.
        """
        if not self.mesh.is_default:
            self.mesh.resolve(robot)
        if "grid" in self.strategies and self.grid_levels:
            levels = max(self.grid_levels)
            if levels**robot.n_inputs > MAX_GRID_CANDIDATES:
                raise self.field_error(
                    f"{self.name_of('grid_levels')} {levels}: a {levels}^{robot.n_inputs} grid has "
                    f"{levels**robot.n_inputs:,} candidate commands; at most {MAX_GRID_CANDIDATES:,} are allowed",
                    "grid_levels",
                )

    def settings(self, samples_per_hour: float) -> dict:
        """What a results file is resumed with only if it was made with the same (its sidecar's
        ``settings``), the capture rate resolved to ``samples_per_hour``.

        Parameters
        ----------
        samples_per_hour : float
            The resolved capture rate (:meth:`capture_rate`).

        Returns
        -------
        dict
            The settings named by :data:`lab.studies.data_curve_run.SETTINGS` (JSON-ready).
        """
        return {
            "robot": self.robot, "rig": self.rig, "model": self.model, "hidden": list(self.hidden),
            "epochs": self.epochs, "heldout_seed": self.heldout_seed, "heldout": self.heldout,
            "n_rings": self.mesh.n_rings, "n_axial": self.mesh.n_axial, "batch": self.batch,
            "n_points": self.n_points, "algorithm": self.algorithm, "n_initial": self.n_initial,
            "tracking": self.tracking, "samples_per_hour": samples_per_hour,
        }  # fmt: skip

    def row_options(self, samples_per_hour: float) -> dict:
        """The keyword arguments of :func:`lab.studies.data_curve.data_curve_row` (but the
        body, the row's plan, the held-out set and the noise).

        Parameters
        ----------
        samples_per_hour : float
            The resolved capture rate (:meth:`capture_rate`).

        Returns
        -------
        dict
            ``model, hidden, epochs, algorithm, batch, n_initial, tracking, n_points, samples_per_hour``.
        """
        return {"model": self.model, "hidden": tuple(self.hidden), "epochs": self.epochs,
                "algorithm": self.algorithm, "batch": self.batch, "n_initial": self.n_initial,
                "tracking": self.tracking, "n_points": self.n_points, "samples_per_hour": samples_per_hour}  # fmt: skip

    def capture_rate(self) -> tuple[float, str]:
        """The capture rate: ``samples_per_hour``, else the ``capture.rate_samples_per_hour``
        of ``rate_from``'s sidecar (the shipped dataset's built-in copy when it is the default
        and not at hand).

        Returns
        -------
        tuple of (float, str)
            Samples per hour, and where the number comes from.
        """
        if self.samples_per_hour is not None:
            return float(self.samples_per_hour), "--samples-per-hour"
        side = Path(self.rate_from if str(self.rate_from).endswith(".json") else f"{self.rate_from}.json")
        if not side.exists() and self.rate_from == DEFAULT_RATE_FROM:  # run outside the repository
            side = Path(__file__).resolve().parents[2] / f"{DEFAULT_RATE_FROM}.json"
        if not side.exists():
            if self.rate_from != DEFAULT_RATE_FROM:
                raise self.field_error(f"{self.name_of('rate_from')} {self.rate_from}: no sidecar {side}", "rate_from")
            return FALLBACK_SAMPLES_PER_HOUR, f"{side} capture.rate_samples_per_hour (built-in copy; file not found)"
        try:
            meta = json.loads(side.read_text())
            rate = float(meta["capture"]["rate_samples_per_hour"])
        except (ValueError, KeyError, TypeError):
            message = f"{self.name_of('rate_from')} {side}: no capture.rate_samples_per_hour in it"
            raise self.field_error(message, "rate_from") from None
        if positive(rate):
            raise self.field_error(
                f"{self.name_of('rate_from')} {side}: capture.rate_samples_per_hour must be finite and > 0, got {rate}",
                "rate_from",
            )
        rig = meta.get("rig", {}).get("kind", "?") if isinstance(meta.get("rig"), dict) else meta.get("rig", "?")
        src = f"{DEFAULT_RATE_FROM}.json" if self.rate_from == DEFAULT_RATE_FROM else str(side)
        return rate, f"{src} capture.rate_samples_per_hour (rig {rig}, the waiting protocol)"
