"""Which commands to measure: the sampling design that ``simulate`` and ``capture`` share.

:class:`DesignSpec` is the one setting behind ``--grid L | --sobol N | --lhs N | --design D
--n N | --active N --batch B`` (and ``--active``'s ensemble). A fixed design (the grid, 7
levels by default, or a space-filling design of :mod:`lab.data.designs`) gives its safe
commands with :meth:`DesignSpec.commands`; an active one is run by
:mod:`lab.learn.active_design`. The spec refuses a bad combination or count when it is
built and :meth:`DesignSpec.check` what does not fit the robot -- both before any work.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lab.data.designs import DESIGNS, MAX_DESIGN_N, MAX_MAXIMIN_N, design_commands, grid_commands, min_distance
from lab.description import RobotDescription
from lab.errors import InputError
from lab.specs import Spec, option

__all__ = ["DesignSpec", "ACTIVE_POOL", "MAX_ACTIVE_N", "MAX_GRID_CANDIDATES", "DEFAULT_GRID_LEVELS"]

#: Grid levels per motor when no sampling flag is given (the paper's 7x7x7 grid).
DEFAULT_GRID_LEVELS = 7
#: Largest grid, in candidate commands (levels^m): the whole grid is built in memory.
MAX_GRID_CANDIDATES = 4_194_304
#: Largest ``--active`` budget (as a design's: its first half is a Sobol design).
MAX_ACTIVE_N = MAX_DESIGN_N
#: Candidates scored per batch of ``--active``: the most one batch can pick.
ACTIVE_POOL = 4096


def _at_least(low: int):
    def check(v) -> str | None:
        ok = isinstance(v, (int, np.integer)) and not isinstance(v, bool) and v >= low
        return None if ok else f"must be at least {low}"

    return check


def _grid_levels(v) -> str | None:
    return None if _at_least(2)(v) is None else "needs at least 2 levels per motor"


@dataclass(frozen=True)
class DesignSpec(Spec):
    """One sampling design; unset, it is the 7-level grid. At most one of ``grid``,
    ``sobol``, ``lhs``, ``design`` and ``active`` is given.

    Attributes
    ----------
    grid : int or None
        Grid levels per motor (>= 2; default 7).
    sobol, lhs : int or None
        N scrambled-Sobol, or Latin-hypercube, safe commands instead of a grid.
    design : str or None
        A space-filling design of :data:`~lab.data.designs.DESIGNS`, of ``n`` commands.
    active : int or None
        N commands picked in batches of ``batch`` where an ensemble disagrees most.
    n : int or None
        Number of commands of ``design``.
    batch : int or None
        Samples per batch of ``active``.
    ensemble_members : int
        Networks of ``active``'s ensemble (>= 2).
    ensemble_hidden : tuple of int
        Hidden layer widths of ``active``'s networks.
    ensemble_epochs : int or None
        Most training epochs per network (None: train's).
    seed : int
        Seeds a design or ``active``'s picks and ensembles (the command's own seed), >= 0.
    """

    grid: int | None = option(help="grid levels per motor (default 7)", type=int, check=_grid_levels)
    sobol: int | None = option(help="N scrambled-Sobol safe commands instead of a grid", type=int, check=_at_least(1))
    lhs: int | None = option(
        help="N commands of a Latin hypercube restricted to the safe set", type=int, check=_at_least(1)
    )
    design: str | None = option(
        help="instead of the grid, --n commands of a space-filling design over the safe set", choices=DESIGNS
    )
    active: int | None = option(
        help="N commands measured in batches of --batch, each where an ensemble trained on the samples "
        "so far disagrees most (the first N/2: a Sobol design)",
        type=int,
        check=_at_least(1),
    )
    n: int | None = option(help="number of commands of --design", type=int, check=_at_least(1))
    batch: int | None = option(help="samples per batch of --active", type=int, check=_at_least(1))
    ensemble_members: int = option(5, help="networks of --active's ensemble", type=int)
    ensemble_hidden: tuple[int, ...] = option((20, 20), help="hidden layer widths of --active's networks", type=int)
    ensemble_epochs: int | None = option(help="most training epochs per network (default: train's)", type=int)
    seed: int = option(0, help="seed of the design or of --active's picks and ensembles", cli=False)

    def __post_init__(self):
        super().__post_init__()
        object.__setattr__(self, "ensemble_hidden", tuple(self.ensemble_hidden))
        name = self.name_of
        chosen = [f for f in ("grid", "sobol", "lhs", "design", "active") if getattr(self, f) is not None]
        if len(chosen) > 1:
            raise self.field_error(f"{' and '.join(map(name, chosen))} are different designs: give one", *chosen)
        for field in ("sobol", "lhs"):
            if getattr(self, field) is not None and self.n is not None:
                message = f"{name('n')} N goes with {name('design')}; {name(field)} N gives the number itself"
                raise self.field_error(message, "n", "design", field)
        if self.active is None and self.batch is not None:
            raise self.field_error(f"{name('batch')} B goes with {name('active')} N", "batch", "active")
        if self.n is not None and self.design is None and self.sobol is None and self.lhs is None:
            raise self.field_error(
                f"{name('n')} N goes with {name('design')} {{{','.join(DESIGNS)}}}; the grid's size is "
                f"{name('grid')} LEVELS",
                "n",
                "design",
                "grid",
            )
        if self.design is not None and self.n is None:
            raise self.field_error(
                f"{name('design')} {self.design} needs the number of commands: {name('n')} N", "design", "n"
            )
        if self.active is not None:
            self._check_active()
        if self.kind == "design":
            limit = MAX_MAXIMIN_N if self.method == "maximin" else MAX_DESIGN_N
            if self.n_commands > limit:
                raise self.field_error(
                    f"{name('design')} {self.method} {name('n')} {self.n_commands}: a {self.method} design takes "
                    f"at most {limit} commands, got n = {self.n_commands}",
                    "design",
                    "n",
                )
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) or self.seed < 0:
            raise self.field_error(f"{name('seed')} must be an integer >= 0, got {self.seed}", "seed")

    def _check_active(self) -> None:
        name = self.name_of
        if self.batch is None:
            raise self.field_error(f"{name('active')} N needs the batch size: {name('batch')} B", "active", "batch")
        if self.active > MAX_ACTIVE_N:
            raise self.field_error(f"{name('active')} must be at most {MAX_ACTIVE_N}, got {self.active}", "active")
        if self.batch > ACTIVE_POOL:
            raise self.field_error(
                f"{name('batch')} must be at most {ACTIVE_POOL} (the candidates scored per batch), got {self.batch}",
                "batch",
            )
        if _at_least(2)(self.ensemble_members):
            message = f"{name('ensemble_members')} must be at least 2, got {self.ensemble_members}"
            raise self.field_error(message, "ensemble_members")
        if not self.ensemble_hidden or any(_at_least(1)(h) for h in self.ensemble_hidden):
            message = f"{name('ensemble_hidden')} widths must be positive, got {list(self.ensemble_hidden)}"
            raise self.field_error(message, "ensemble_hidden")
        if self.ensemble_epochs is not None and _at_least(1)(self.ensemble_epochs):
            message = f"{name('ensemble_epochs')} must be at least 1, got {self.ensemble_epochs}"
            raise self.field_error(message, "ensemble_epochs")

    # --- what the flags mean ----------------------------------------------------------------

    @property
    def kind(self) -> str:
        """``"grid"``, ``"design"`` (a space-filling design) or ``"active"``."""
        if self.active is not None:
            return "active"
        return "grid" if self.method == "grid" else "design"

    @property
    def method(self) -> str:
        """``"grid"``, ``"active"`` or the space-filling design (``--sobol N`` is ``sobol``)."""
        if self.active is not None:
            return "active"
        if self.sobol is not None:
            return "sobol"
        if self.lhs is not None:
            return "lhs"
        return self.design or "grid"

    @property
    def levels(self) -> int | None:
        """Grid levels per motor (None unless a grid)."""
        if self.kind != "grid":
            return None
        return DEFAULT_GRID_LEVELS if self.grid is None else self.grid

    @property
    def n_commands(self) -> int | None:
        """Commands of a space-filling design, or ``--active``'s budget (None for a grid)."""
        if self.kind == "active":
            return self.active
        return next((v for v in (self.sobol, self.lhs, self.n) if v is not None), None)

    def words(self) -> list[str]:
        """The flags that reproduce this design.

        Returns
        -------
        list of str
            The command-line words (``--sobol N`` as ``--design sobol --n N``).
        """
        if self.kind == "active":
            words = ["--active", str(self.active), "--batch", str(self.batch)]
            words += ["--ensemble-members", str(self.ensemble_members)]
            words += ["--ensemble-hidden", *map(str, self.ensemble_hidden)]
            return words + (["--ensemble-epochs", str(self.ensemble_epochs)] if self.ensemble_epochs else [])
        if self.kind == "design":
            return ["--design", self.method, "--n", str(self.n_commands)]
        return ["--grid", str(self.levels)]

    # --- for a robot --------------------------------------------------------------------------

    def check(self, robot: RobotDescription) -> None:
        """Refuse (InputError) what does not fit ``robot``: a grid over
        :data:`MAX_GRID_CANDIDATES` candidate commands.

        Parameters
        ----------
        robot : RobotDescription
            Gives the number of motors m.
        """
        if self.kind == "grid":
            n = self.levels**robot.n_inputs
            if n > MAX_GRID_CANDIDATES:
                raise self.field_error(
                    f"{self.name_of('grid')} {self.levels}: a {self.levels}^{robot.n_inputs} grid has {n:,} "
                    "candidate commands; "
                    f"at most {MAX_GRID_CANDIDATES:,} are allowed (a grid is built whole in memory)",
                    "grid",
                )

    def commands(self, robot: RobotDescription) -> tuple[np.ndarray, dict]:
        """The safe commands of a grid or space-filling design, in design order. Not for ``active``.

        Parameters
        ----------
        robot : RobotDescription
            Gives each input's range and the safety limits.

        Returns
        -------
        u_motor : numpy.ndarray
            The commands (N, m), each input in its unit (rad, N).
        sampler : dict
            The sampler's metadata (JSON-able).
        """
        if self.kind == "active":
            raise self.field_error(
                f"a design of {self.name_of('active')} is picked as it is measured: it has no fixed commands", "active"
            )
        self.check(robot)
        if self.kind == "grid":
            u = grid_commands(robot, self.levels)
            n_candidates = self.levels**robot.n_inputs
            return u, {"name": "grid", "levels": self.levels, "n_candidates": n_candidates, "n_safe": len(u)}
        method, n = self.method, self.n_commands
        try:
            u = design_commands(robot, n, method, seed=self.seed)
        except InputError as err:
            name = self.name_of
            raise self.field_error(f"{name('design')} {method} {name('n')} {n}: {err}", "design", "n") from None
        return u, {
            "name": method,
            "n": n,
            "seed": self.seed,
            "space": "safe set of [0, u_max]^m, distances in u / u_max"
            if robot.all_angle
            else "safe set of [u_lower, u_upper], distances in (u - u_lower) / (u_upper - u_lower)",
            "min_distance": min_distance(robot, u),
        }
