"""Simulated (u, y) data: solving the statics of every sampled command (:mod:`lab.data.designs`).

:func:`simulate` solves the statics of every command. The work is cut into chunks
that depend only on the commands (never on the number of workers); each chunk walks
its commands in an order where neighbours are close and warm-starts every solve from
a prediction built from the equilibria already solved in that walk
(:mod:`lab.fem.solve.warmstart`). Chunks run on joblib worker processes, and since each chunk's
computation is the same wherever it runs, a parallel run gives exactly the serial
run's numbers.
"""

from __future__ import annotations

import os
import time

import numpy as np

from lab.data.chunks import Chunk
from lab.description import RobotDescription
from lab.errors import LabRuntimeError
from lab.fem.model import ArmFEM
from lab.fem.solve.statics import solve_static
from lab.fem.solve.warmstart import WalkPredictor
from lab.workers import default_jobs, kill_local_workers, watch_parent  # noqa: F401  (default_jobs: re-exported)

#: How many predictions (best first) a solve may start from before it accepts one where
#: the exact Hessian is indefinite (each try costs one assembly and factorisation).
START_TRIES = 3
_FEM_CACHE: dict = {}


def _fem(robot: RobotDescription, n_rings: int, n_axial: int) -> ArmFEM:
    key = (robot.sha256, n_rings, n_axial)
    if key not in _FEM_CACHE:
        _FEM_CACHE.clear()
        _FEM_CACHE[key] = ArmFEM(robot, n_rings=n_rings, n_axial=n_axial)
    return _FEM_CACHE[key]


def solve_chunk(robot: RobotDescription, n_rings: int, n_axial: int, u_chunk: np.ndarray) -> dict:
    """Solve a walk of commands with warm starts, starting from rest.

    Each solve starts from the best prediction of :class:`lab.fem.solve.warmstart.WalkPredictor`
    where the exact Hessian is positive definite, if one of the first ``START_TRIES`` is
    (starting where it is not costs several extra factorisations; the best prediction
    was such a start at 2 of the 308 grid points), and refines dq/du along
    the walk's steps into and out of its command, which the next predictions use.
    Per sample, ``iterations``, ``factorizations`` and ``time_s`` count all of that.

    Parameters
    ----------
    robot : RobotDescription
        The robot.
    n_rings, n_axial : int
        The mesh's resolution.
    u_chunk : numpy.ndarray
        The walk's commands (L, m), each input in its unit (rad, N), in order.

    Returns
    -------
    dict
        ``p_tip_W`` (L, 3) m, frame W; ``y_W`` (L, 3K) m, frame W: every marker
        (:attr:`lab.fem.ArmFEM.marker_names`, the tip first); ``iterations`` (L,),
        ``factorizations`` (L,) and ``time_s`` (L,) s.
    """
    fem = _fem(robot, n_rings, n_axial)
    walk = [np.zeros(robot.n_inputs)] + [np.asarray(u, float) for u in u_chunk]
    predictor = WalkPredictor(fem)
    tips, ys, iters, facts, times = [], [], [], [], []
    for k, u in enumerate(walk):
        steps = [walk[j + 1] - walk[j] for j in (k - 1, k) if 0 <= j < len(walk) - 1]
        kw = dict(sensitivity="reuse", raise_on_failure=False, refine_du=np.array(steps))
        t0 = time.perf_counter()
        starts = [q for _, q in predictor.ranked(u)] or ([predictor.last.q] if predictor.last else [None])
        solves = []
        for q0 in starts[:START_TRIES]:
            solves.append(solve_static(fem, u, q0, stop_if_indefinite=True, **kw))
            if solves[-1].status != "indefinite":
                break
        else:  # indefinite everywhere tried: start from the best anyway
            solves.append(solve_static(fem, u, starts[0], **kw))
        if not solves[-1].converged:  # fall back to a cold start before giving up
            solves.append(solve_static(fem, u, **kw))
        sol = solves[-1]
        predictor.add(sol)
        if k == 0:
            continue  # the rest state every walk starts from
        tips.append(sol.p_tip_W), ys.append(np.ravel(sol.y_W)), times.append(time.perf_counter() - t0)
        iters.append(sum(s.iterations for s in solves)), facts.append(sum(s.factorizations for s in solves))
    return {
        "p_tip_W": np.asarray(tips).reshape(-1, 3),
        "y_W": np.asarray(ys).reshape(len(tips), 3 * len(fem.marker_names)),
        "iterations": np.asarray(iters),
        "factorizations": np.asarray(facts),
        "time_s": np.asarray(times),
    }


def _solve_indexed(i: int, robot: RobotDescription, n_rings: int, n_axial: int, u_chunk: np.ndarray):
    watch_parent()  # a worker exits once its run is gone (kill -9)
    return i, solve_chunk(robot, n_rings, n_axial, u_chunk)


def simulate(
    robot: RobotDescription,
    u_motor: np.ndarray,
    chunks: list[Chunk],
    *,
    n_rings: int | None = None,
    n_axial: int | None = None,
    n_jobs: int = 1,
    progress: bool = False,
    checkpoint: str | os.PathLike | None = None,
    scheduler: str | None = None,
) -> dict:
    """Tip and marker positions for commands, solved chunk by chunk.

    Parameters
    ----------
    robot : RobotDescription
        The robot.
    u_motor : numpy.ndarray
        Commands (N, m), each input in its unit (rad, N).
    chunks : list of Chunk
        The walks covering every command (:mod:`lab.data.chunks`).
    n_rings, n_axial : int, optional
        The mesh's resolution; default the robot's.
    n_jobs : int
        Worker processes (joblib/loky, one BLAS/MKL thread each); 1 runs here.
    progress : bool
        Show a progress bar (the samples done and an ETA).
    checkpoint : str or os.PathLike, optional
        A directory where each finished chunk is stored at once; a run started again with
        the same arguments loads those and solves only the rest (see :mod:`lab.data.chunkstore`).
    scheduler : str, optional
        The address of a Dask scheduler (``tcp://host:port``) to run the chunks on a cluster
        through joblib's Dask backend instead of local processes (its workers need this
        package installed and should run one thread each, e.g. ``dask worker --nthreads 1``
        with ``OMP_NUM_THREADS=1``).

    Returns
    -------
    dict
        ``p_tip_W`` (N, 3) m, frame W, ``y_W`` (N, 3K) m, frame W (every marker of
        ``robot.marker_names``, the tip first), plus per-sample ``iterations``, ``factorizations`` and
        ``time_s`` (s), ``wall_s`` (s) and ``resumed_samples`` (how many came from the checkpoint).
    """
    from joblib import Parallel, delayed, parallel_config
    from tqdm.auto import tqdm

    from lab.data.chunkstore import ChunkStore, fingerprint
    from lab.workers import worker_config

    n_rings, n_axial = n_rings or robot.n_rings, n_axial or robot.n_axial
    t0 = time.perf_counter()
    p_tip = np.full((len(u_motor), 3), np.nan)
    n_markers = len(robot.marker_names)
    y_all = np.full((len(u_motor), 3 * n_markers), np.nan)
    iters = np.zeros(len(u_motor), dtype=int)
    facts = np.zeros(len(u_motor), dtype=int)
    times = np.zeros(len(u_motor))
    orders = [c.order for c in chunks]
    store, done = None, {}
    if checkpoint is not None:
        store = ChunkStore(checkpoint, fingerprint(robot.sha256, n_rings, n_axial, u_motor, orders))
        done = store.load(orders, u_motor)

    def record(i, res):
        order = orders[i]
        y = np.asarray(res["y_W"]).reshape(len(order), -1)
        if y.shape[1] != y_all.shape[1]:
            raise LabRuntimeError(
                f"{robot.name}: the FEM observed {y.shape[1] // 3} marker(s) but the description names "
                f"{n_markers} ({', '.join(robot.marker_names)})"
            )
        p_tip[order], iters[order], times[order] = res["p_tip_W"], res["iterations"], res["time_s"]
        y_all[order] = y
        facts[order] = res["factorizations"]

    for i, res in done.items():
        record(i, res)
    resumed = sum(len(orders[i]) for i in done)
    bar = tqdm(total=len(u_motor), initial=resumed, unit="sample", disable=not progress, smoothing=0.05)
    todo = [i for i in range(len(chunks)) if i not in done]
    jobs = (delayed(_solve_indexed)(i, robot, n_rings, n_axial, u_motor[orders[i]]) for i in todo)
    client = None
    try:
        if scheduler is not None:
            from distributed import Client

            client = Client(scheduler)
            config = parallel_config(backend="dask")
            n_jobs = -1
        else:
            config = worker_config()
        with config:
            runner = Parallel(n_jobs=n_jobs, return_as="generator_unordered")
            for i, res in runner(jobs):
                if store is not None:
                    store.save(i, {"order": orders[i], "u_motor": u_motor[orders[i]], **res})
                record(i, res)
                bar.update(len(orders[i]))
    except BaseException:
        if scheduler is None and n_jobs != 1:
            kill_local_workers()  # do not leave them computing chunks nobody will collect
        raise
    finally:
        bar.close()
        if client is not None:
            client.close()
    return {
        "p_tip_W": p_tip,
        "y_W": y_all,
        "iterations": iters,
        "factorizations": facts,
        "time_s": times,
        "wall_s": time.perf_counter() - t0,
        "resumed_samples": resumed,
    }
