import json
import subprocess
import sys

import numpy as np
import pytest

from lab.data.chunks import _serpentine, grid_chunks, nearest_neighbour_chunks, nearest_walk
from lab.data.dataset import DatasetError, read_dataset, write_dataset
from lab.data.designs import grid_commands, sobol_commands
from lab.data.simulation import simulate
from lab.fem.model import ArmFEM
from lab.fem.solve.statics import solve_static


def test_serpentine_walk_moves_one_step_at_a_time():
    keys = np.array([(i, j, k) for i in range(3) for j in range(4) for k in range(5)])
    walk = keys[_serpentine(keys)]
    assert len({tuple(k) for k in walk}) == len(keys)
    assert np.all(np.abs(np.diff(walk, axis=0)).sum(axis=1) == 1)


def test_nearest_walk_starts_nearest_rest_and_steps_to_the_nearest_left():
    u = np.array([[3.0, 0.0], [0.5, 0.5], [2.9, 0.2], [0.0, 0.2], [1.0, 1.0]])
    assert nearest_walk(u).tolist() == [3, 1, 4, 2, 0]  # L1 distances from rest, then from each
    u = np.random.default_rng(0).uniform(0, 2, (40, 3))
    order = nearest_walk(u)
    assert sorted(order) == list(range(40)) and order[0] == np.argmin(np.abs(u).sum(axis=1))
    for k in range(1, 39):  # each step goes to the nearest command not yet visited
        left = order[k:]
        assert order[k] == left[np.argmin(np.abs(u[left] - u[order[k - 1]]).sum(axis=1))]
    assert nearest_walk(np.zeros((0, 3))).tolist() == []


def test_grid_chunks_cover_every_command_once(three_cable):
    u = grid_commands(three_cable, 7)
    chunks = grid_chunks(three_cable, u)
    order = np.concatenate([c.order for c in chunks])
    assert sorted(order) == list(range(len(u)))
    # every chunk starts at its corner nearest rest (its leading index, zeros after)
    for c in chunks:
        assert np.all(u[c.order[0], 1:] == 0)


def test_sobol_commands_are_safe_and_seeded(three_cable):
    a, b = sobol_commands(three_cable, 50, seed=3), sobol_commands(three_cable, 50, seed=3)
    assert a.shape == (50, 3) and np.array_equal(a, b)
    assert np.all(three_cable.is_safe(a))
    assert not np.array_equal(a, sobol_commands(three_cable, 50, seed=4))
    order = np.concatenate([c.order for c in nearest_neighbour_chunks(a, size=16)])
    assert sorted(order) == list(range(50))


@pytest.mark.slow
def test_parallel_run_is_identical_to_serial_and_to_cold_solves(three_cable, coarse_fem, tmp_path):
    u = grid_commands(three_cable, 4)
    chunks = grid_chunks(three_cable, u, target_size=16)
    assert len(chunks) > 2
    kw = dict(n_rings=1, n_axial=6)
    serial = simulate(three_cable, u, chunks, n_jobs=1, **kw)
    parallel = simulate(three_cable, u, chunks, n_jobs=2, **kw)
    # Same chunks, same walks, same arithmetic: equal to rounding. (Bitwise equality holds
    # between fresh processes, checked below; inside a long-lived test worker, alignment-
    # dependent SIMD paths in NumPy/MKL were seen to move the last bit, 7e-16 m.)
    assert np.abs(serial["p_tip_W"] - parallel["p_tip_W"]).max() < 1e-12
    code = (
        "import sys, numpy as np; from lab.description import load_robot; "
        "from lab.data import grid_chunks, grid_commands, simulate; r = load_robot('three-cable'); "
        "u = grid_commands(r, 4); res = simulate(r, u, grid_chunks(r, u, target_size=16), n_rings=1, n_axial=6); "
        "np.save(sys.argv[1], res['p_tip_W'])"
    )
    out = tmp_path / "serial.npy"
    subprocess.run([sys.executable, "-c", code, str(out)], check=True, timeout=300)
    assert np.array_equal(np.load(out), parallel["p_tip_W"])
    # Warm starts change the path to the equilibrium, not the equilibrium.
    for i in [0, len(u) // 2, len(u) - 1]:
        cold = solve_static(coarse_fem, u[i], tol_step_m=1e-11).p_tip_W
        assert np.allclose(serial["p_tip_W"][i], cold, rtol=0, atol=1e-8)


def test_dataset_round_trip_and_corruption(tmp_path):
    u = np.random.default_rng(0).uniform(0, 3, (5, 3))
    y = np.random.default_rng(1).normal(size=(5, 3))
    path = tmp_path / "d.csv"
    write_dataset(path, u, y, {"sampler": {"name": "test"}})
    u2, y2, meta = read_dataset(path)
    assert np.array_equal(u, u2) and np.array_equal(y, y2)  # repr() round-trips floats exactly
    assert meta["sampler"]["name"] == "test" and meta["n_samples"] == 5
    assert path.read_text().splitlines()[0] == "u0,u1,u2,x,y,z"
    assert not list(tmp_path.glob(".*tmp*"))  # no temporary files left behind

    lines = path.read_text().splitlines()
    path.write_text("\n".join(lines[:-1]) + "\n")
    with pytest.raises(DatasetError, match="sidecar says 5"):
        read_dataset(path)
    path.write_text("\n".join(lines[:3] + ["1,2,nan,4,5,6"] + lines[4:]) + "\n")
    with pytest.raises(DatasetError, match="line 4 has a NaN"):
        read_dataset(path)
    path.write_text("\n".join(lines[:2] + ["1,2,oops,4,5,6"] + lines[3:]) + "\n")
    with pytest.raises(DatasetError, match="non-numeric"):
        read_dataset(path)
    path.write_text("a,b,c\n" + "\n".join(lines[1:]) + "\n")
    with pytest.raises(DatasetError, match="header"):
        read_dataset(path)
    path.write_text("\n".join(lines) + "\n")
    meta["format_version"] = 99
    (tmp_path / "d.csv.json").write_text(json.dumps(meta))
    with pytest.raises(DatasetError, match="format_version 99"):
        read_dataset(path)
    with pytest.raises(DatasetError, match="not found"):
        read_dataset(tmp_path / "missing.csv")


def test_cli_simulate_writes_dataset_and_sidecar(tmp_path, three_cable):
    out = tmp_path / "sim.csv"
    cmd = [
        sys.executable,
        "-m",
        "lab",
        "simulate",
        "--robot",
        "three-cable",
        "--grid",
        "3",
        "--n-rings",
        "1",
        "--n-axial",
        "6",
        "--jobs",
        "1",
        "--no-progress",
        "--out",
        str(out),
    ]
    run = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    u, y, meta = read_dataset(out)
    assert len(u) == len(grid_commands(three_cable, 3)) == 23
    assert meta["robot"]["sha256"] == three_cable.sha256
    assert meta["mesh"] == {"mesher": "cylinder", "n_rings": 1, "n_axial": 6, "n_nodes": 49, "n_tets": 108}
    assert meta["sampler"]["name"] == "grid" and meta["sampler"]["levels"] == 3
    for key in ("code_version", "created", "command"):
        assert meta[key]
    assert np.all(y[:, 0] > 0.1)  # tips in metres, near x = 20 cm

    bad = subprocess.run(
        cmd[:5] + ["no-such-robot", "--out", str(tmp_path / "x.csv")], capture_output=True, text=True, timeout=60
    )
    assert bad.returncode == 2 and "unknown robot 'no-such-robot'" in bad.stderr


def test_checkpoint_resumes_and_refuses_another_run(tmp_path, three_cable):
    from lab.data.chunkstore import CheckpointError

    u = grid_commands(three_cable, 3)
    chunks = grid_chunks(three_cable, u, target_size=4)
    kw = dict(n_rings=1, n_axial=6)
    full = simulate(three_cable, u, chunks, **kw)
    ckpt = tmp_path / "ckpt"
    first = simulate(three_cable, u, chunks, checkpoint=ckpt, **kw)
    assert first["resumed_samples"] == 0 and len(list(ckpt.glob("chunk_*.npz"))) == len(chunks)
    # Lose two chunks (as if the run had been killed before them) and corrupt a third.
    (ckpt / "chunk_00001.npz").unlink()
    (ckpt / "chunk_00003.npz").unlink()
    (ckpt / "chunk_00004.npz").write_bytes(b"PK\x03\x04 truncated")
    again = simulate(three_cable, u, chunks, checkpoint=ckpt, **kw)
    lost = sum(len(chunks[i].order) for i in (1, 3, 4))
    assert again["resumed_samples"] == len(u) - lost
    assert np.abs(again["p_tip_W"] - full["p_tip_W"]).max() < 1e-12
    # Same directory, other commands: refused, not mixed in.
    with pytest.raises(CheckpointError, match="another run"):
        simulate(three_cable, u[:-1], grid_chunks(three_cable, u[:-1], target_size=4), checkpoint=ckpt, **kw)


@pytest.mark.slow
def test_cli_simulate_killed_midway_resumes_without_loss(tmp_path, three_cable):
    import os
    import signal
    import time

    out = tmp_path / "sim.csv"
    cmd = [
        sys.executable,
        "-m",
        "lab",
        "simulate",
        "--grid",
        "5",
        "--n-rings",
        "1",
        "--n-axial",
        "8",
        "--chunk-size",
        "5",
        "--jobs",
        "1",
        "--no-progress",
        "--out",
        str(out),
    ]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    ckpt = tmp_path / "sim.csv.chunks"
    deadline = time.monotonic() + 120
    while len(list(ckpt.glob("chunk_*.npz"))) < 3 and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.005)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    n_done = len(list(ckpt.glob("chunk_*.npz")))
    assert not out.exists() and n_done >= 3, "the run should have been killed part-way"

    run = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert "resumed" in run.stderr and not ckpt.exists()
    u, y, meta = read_dataset(out)
    ref = simulate(three_cable, u, grid_chunks(three_cable, u, target_size=5), n_rings=1, n_axial=8)
    assert meta["solver"]["resumed_samples"] > 0
    assert np.abs(y - ref["p_tip_W"]).max() < 1e-12


@pytest.mark.slow
def test_dask_local_cluster_gives_the_serial_numbers(three_cable):
    from distributed import LocalCluster

    u = grid_commands(three_cable, 3)
    chunks = grid_chunks(three_cable, u, target_size=4)
    kw = dict(n_rings=1, n_axial=6)
    serial = simulate(three_cable, u, chunks, **kw)
    with LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", scheduler_port=0, dashboard_address=":0"
    ) as cluster:
        assert cluster.scheduler_address.startswith("tcp://127.0.0.1:")
        dask = simulate(three_cable, u, chunks, scheduler=cluster.scheduler_address, **kw)
    assert np.abs(dask["p_tip_W"] - serial["p_tip_W"]).max() < 1e-12


@pytest.mark.slow
def test_cli_simulate_stops_its_workers_on_sigterm(tmp_path):
    import os
    import signal
    import time

    import psutil

    cmd = [
        sys.executable,
        "-m",
        "lab",
        "simulate",
        "--grid",
        "7",
        "--n-rings",
        "1",
        "--n-axial",
        "10",
        "--chunk-size",
        "64",
        "--jobs",
        "2",
        "--no-progress",
        "--out",
        str(tmp_path / "sim.csv"),
    ]
    err_file = (tmp_path / "stderr.txt").open("w")
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=err_file)
    deadline = time.monotonic() + 120
    workers = []
    while time.monotonic() < deadline and proc.poll() is None:
        workers = [
            p for p in psutil.Process(proc.pid).children(recursive=True) if "LokyProcess" in " ".join(p.cmdline())
        ]
        if len(workers) == 2:
            break
        time.sleep(0.05)
    assert len(workers) == 2, "the run should have started its two workers"
    time.sleep(1.0)  # they are computing chunks now
    proc.send_signal(signal.SIGTERM)
    assert proc.wait(timeout=30) == 128 + signal.SIGTERM
    err_file.close()
    err = (tmp_path / "stderr.txt").read_text()
    assert "interrupted by SIGTERM; stopped cleanly" in err and "Traceback" not in err, err  # the shared handling
    gone, alive = psutil.wait_procs(workers, timeout=10)
    for p in alive:
        os.kill(p.pid, signal.SIGKILL)
    assert not alive, "workers outlived the killed run"


def test_walk_predictor_hermite_and_row_corrections(three_cable, coarse_fem):
    from lab.fem.solve.warmstart import WalkPredictor

    fem = coarse_fem
    pred = WalkPredictor(fem)
    assert pred.ranked([0, 0, 1.0]) == []
    # Two rows of a serpentine walk: u1 = 1 with u2 = 0.5, 1, 1.5, then u1 = 1.5 backwards.
    walk = [np.array([0, 1.0, u2]) for u2 in (0.5, 1.0, 1.5)] + [np.array([0, 1.5, u2]) for u2 in (1.5, 1.0)]
    for k, u in enumerate(walk):
        steps = [walk[j + 1] - walk[j] for j in (k - 1, k) if 0 <= j < len(walk) - 1]
        pred.add(
            solve_static(
                fem, u, None if k == 0 else pred.ranked(u)[0][1], sensitivity="reuse", refine_du=np.array(steps)
            )
        )
    exact = {}

    def err(u, q):
        key = tuple(u)
        if key not in exact:
            exact[key] = solve_static(fem, u, tol_step_m=1e-11).q
        return np.abs(q - exact[key]).max()

    # Straight on along the first row: Hermite beats linear by far.
    u = np.array([0, 1.0, 2.0])
    names = {k: q for k, q, _ in pred.candidates(u)}
    assert err(u, names["hermite"]) < 0.1 * err(u, names["linear"])
    # Second row, going back: the row-back correction beats the plain linear step, and
    # the ranking (by energy) puts a corrected prediction first.
    u = np.array([0, 1.5, 0.5])
    cands = pred.candidates(u)
    kinds = [k for k, _, _ in cands]
    assert "linear corrected" in kinds and "hermite corrected" in kinds
    lin = next(q for k, q, _ in cands if k == "linear")
    best_kind, best = pred.ranked(u)[0]
    assert "corrected" in best_kind and err(u, best) < 0.5 * err(u, lin)


@pytest.mark.slow
def test_warm_walks_need_few_factorisations(three_cable):
    """Regression guard for the warm starts: ~4.6 factorisations per sample before the
    predictor, condensed and chord steps (issue: sample cost < 3 factorisations)."""
    u = grid_commands(three_cable, 5)
    chunks = grid_chunks(three_cable, u)
    res = simulate(three_cable, u, chunks, n_rings=1, n_axial=8)
    warm = np.concatenate([c.order[1:] for c in chunks])
    assert res["factorizations"][warm].mean() < 3.2
    fem = ArmFEM(three_cable, n_rings=1, n_axial=8)
    for i in warm[::7]:
        cold = solve_static(fem, u[i], tol_step_m=1e-11).p_tip_W
        assert np.abs(res["p_tip_W"][i] - cold).max() < 1e-8


def test_walk_predictor_ranks_implausible_cable_states_last(coarse_fem, monkeypatch):
    from lab.fem.solve.warmstart import WalkPredictor, _Solved

    fem = coarse_fem
    u, ref_u = np.array([0, 1.0, 1.0]), np.array([0, 1.0, 0.5])
    best = solve_static(fem, u).q
    pred = WalkPredictor(fem)
    taut = pred._taut(best, u)
    assert taut[1]  # pulled by motor 1
    true_ref = _Solved(ref_u, best, None, taut)
    odd_ref = _Solved(ref_u, best, None, (taut[0], False, taut[2]))  # motor 1 did not move, yet it flips
    worse = best + 1e-4 * np.random.default_rng(0).standard_normal(best.shape)
    monkeypatch.setattr(pred, "candidates", lambda u_: [("a", best, [odd_ref]), ("b", worse, [true_ref])])
    assert fem.energy(best, u) < fem.energy(worse, u)
    assert [k for k, _ in pred.ranked(u)] == ["b", "a"]
    monkeypatch.setattr(pred, "candidates", lambda u_: [("a", best, [true_ref]), ("b", worse, [true_ref])])
    assert [k for k, _ in pred.ranked(u)] == ["a", "b"]
