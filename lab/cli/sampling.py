"""The sampling flags that ``simulate`` and ``capture`` share: which commands to measure.

    --grid L | --sobol N | --lhs N | --design {random,sobol,maximin,lhs} --n N | --active N --batch B

``--grid`` (the default, 7 levels), ``--sobol``, ``--lhs`` and ``--design`` give a fixed
list of safe commands (:mod:`lab.data.designs`); ``--active N --batch B`` measures ``N``
commands chosen batch by batch where an ensemble of ``--ensemble-members`` networks
disagrees most (:func:`lab.learn.active.active_sampling`).
"""

from __future__ import annotations

import numpy as np

from lab.errors import InputError

#: lab.data.designs.DESIGNS (not imported here: the CLI's start stays light).
DESIGN_CHOICES = ("random", "sobol", "maximin", "lhs")


def add_sampler_args(p) -> None:
    """Add the sampling flags to the parser ``p`` (its ``--seed`` is the command's own)."""
    g = p.add_mutually_exclusive_group()
    g.add_argument("--grid", type=int, metavar="LEVELS", help="grid levels per motor (default 7)")
    g.add_argument("--sobol", type=int, metavar="N", help="N scrambled-Sobol safe commands instead of a grid")
    g.add_argument("--lhs", type=int, metavar="N", help="N commands of a Latin hypercube restricted to the safe set")
    g.add_argument(
        "--design",
        choices=DESIGN_CHOICES,
        help="instead of the grid, --n commands of a space-filling design over the safe set",
    )
    g.add_argument(
        "--active",
        type=int,
        metavar="N",
        help="N commands measured in batches of --batch, each where an ensemble trained on the samples "
        "so far disagrees most (the first N/2: a Sobol design)",
    )
    p.add_argument("--n", type=int, metavar="N", help="number of commands of --design")
    p.add_argument("--batch", type=int, metavar="B", help="samples per batch of --active")
    p.add_argument(
        "--ensemble-members", type=int, default=5, metavar="K", help="networks of --active's ensemble (default 5)"
    )
    p.add_argument(
        "--ensemble-hidden",
        type=int,
        nargs="+",
        default=[20, 20],
        metavar="WIDTH",
        help="hidden layer widths of --active's networks (default: 20 20)",
    )
    p.add_argument(
        "--ensemble-epochs", type=int, metavar="E", help="most training epochs per network (default: train's)"
    )


def check_sampler_args(args) -> None:
    """Refuse a bad combination of sampling flags (InputError) before any file is touched.
    Normalises: ``--sobol N`` / ``--lhs N`` become ``--design sobol|lhs --n N``; no flag
    means ``--grid 7``."""
    for flag in ("sobol", "lhs"):
        n = getattr(args, flag)
        if n is not None:
            if n < 1:
                raise InputError(f"--{flag} must be at least 1, got {n}")
            if args.n is not None:
                raise InputError(f"--n N goes with --design; --{flag} N gives the number itself")
            args.design, args.n = flag, n
    if args.active is None and args.batch is not None:
        raise InputError("--batch B goes with --active N")
    if args.design is None:
        if args.n is not None:
            raise InputError(
                f"--n N goes with --design {{{','.join(DESIGN_CHOICES)}}}; the grid's size is --grid LEVELS"
            )
        if args.active is None:
            args.grid = 7 if args.grid is None else args.grid
    elif args.n is None:
        raise InputError(f"--design {args.design} needs the number of commands: --n N")
    elif args.n < 1:
        raise InputError(f"--n must be at least 1, got {args.n}")
    if args.active is not None:
        if args.batch is None:
            raise InputError("--active N needs the batch size: --batch B")
        if args.active < 1 or args.batch < 1:
            raise InputError(f"--active and --batch must be at least 1, got {args.active} and {args.batch}")
        if args.ensemble_members < 2:
            raise InputError(f"--ensemble-members must be at least 2, got {args.ensemble_members}")
        if any(h < 1 for h in args.ensemble_hidden):
            raise InputError(f"--ensemble-hidden widths must be positive, got {args.ensemble_hidden}")
        if args.ensemble_epochs is not None and args.ensemble_epochs < 1:
            raise InputError(f"--ensemble-epochs must be at least 1, got {args.ensemble_epochs}")
    if args.grid is not None and args.grid < 2:
        raise InputError(f"--grid needs at least 2 levels per motor, got {args.grid}")
    if args.seed < 0:
        raise InputError(f"--seed must be an integer >= 0, got {args.seed}")


def sampler_words(args) -> list[str]:
    """The flags that reproduce the sampling of ``args`` (after :func:`check_sampler_args`)."""
    if args.active is not None:
        words = ["--active", str(args.active), "--batch", str(args.batch)]
        words += ["--ensemble-members", str(args.ensemble_members)]
        words += ["--ensemble-hidden", *map(str, args.ensemble_hidden)]
        return words + (["--ensemble-epochs", str(args.ensemble_epochs)] if args.ensemble_epochs else [])
    if args.design is not None:
        return ["--design", args.design, "--n", str(args.n)]
    return ["--grid", str(args.grid)]


def fixed_commands(args, robot) -> tuple[np.ndarray, dict]:
    """The commands (N, m) rad of ``--grid`` or ``--design`` and the sampler's metadata."""
    from lab.data.designs import design_commands, grid_commands, min_distance

    if args.design is None:
        u = grid_commands(robot, args.grid)
        return u, {"name": "grid", "levels": args.grid, "n_candidates": args.grid**robot.n_cables, "n_safe": len(u)}
    try:
        u = design_commands(robot, args.n, args.design, seed=args.seed)
    except InputError as err:
        raise InputError(f"--design {args.design} --n {args.n}: {err}") from None
    return u, {
        "name": args.design,
        "n": args.n,
        "seed": args.seed,
        "space": "safe set of [0, u_max]^m, distances in u / u_max",
        "min_distance": min_distance(robot, u),
    }


def active_settings(args, robot) -> dict:
    """The settings of ``--active`` (JSON-able; what a resumed run must share) and the
    keyword arguments of :func:`lab.learn.active.active_sampling` under ``"kwargs"``."""
    from lab.learn.active import default_initial, default_radius

    settings = {
        "name": "active",
        "n": args.active,
        "batch": args.batch,
        "seed": args.seed,
        "initial_design": "sobol",
        "n_initial": default_initial(args.active),
        "pool_size": 4096,
        "radius": default_radius(args.active, robot.n_cables),
        "density_radius": 0.3,
        "ensemble": {
            "trainer": "lab.learn.ensemble.train_ensemble",
            "members": args.ensemble_members,
            "hidden": list(args.ensemble_hidden),
            "epochs": args.ensemble_epochs,
        },
    }
    kwargs = dict(
        n_initial=settings["n_initial"],
        pool_size=settings["pool_size"],
        radius=settings["radius"],
        density_radius=settings["density_radius"],
        hidden=tuple(args.ensemble_hidden),
        k=args.ensemble_members,
        seed=args.seed,
        epochs=args.ensemble_epochs,
    )
    return {**settings, "kwargs": kwargs}


def print_batch(entry: dict, n_total: int, file) -> None:
    """One line per measured batch of ``--active`` on ``file``."""
    done = entry["n_before"] + entry["n"]
    if entry["kind"] == "initial":
        print(f"batch 0: initial {entry['design']} design, {entry['n']} commands ({done}/{n_total})", file=file)
        return
    print(
        f"batch {entry['batch']}: {entry['n']} commands ({done}/{n_total}); ensemble spread in the pool "
        f"mean {1e3 * entry['pool_spread_mean_m']:.3f} mm max {1e3 * entry['pool_spread_max_m']:.3f} mm, "
        f"of the picks mean {1e3 * entry['picked_spread_mean_m']:.3f} mm (fit {entry['fit_s']:.1f} s)",
        file=file,
    )
