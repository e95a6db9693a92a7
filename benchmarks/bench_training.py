"""Training speed and scale: BR 3-30-3 against lab's GP, the README's ensemble, 20,000 rows.

    python benchmarks/bench_training.py --baseline 2e876ae --out benchmarks/bench_training.txt
    python benchmarks/bench_training.py --quick            # a smoke run: 2 splits, small sets
    python benchmarks/bench_training.py --only splits      # or recipe, large

Everything runs on one BLAS thread (OMP/OPENBLAS/MKL = 1, set before NumPy loads; the
command-line runs of section B say their own) and is timed in process CPU time
(``time.process_time``; a command line's by ``getrusage`` of its process tree), paired runs
interleaved split by split, so a busy machine slows both sides alike.

A. **The ten splits of the emulated robot** (``data/real_three_cable.csv``, the splits of
   ``python -m lab splits --model gpr`` and ``splits --algorithm br --hidden 30 --min-grad 0``:
   seeds ``lab.learn.run_seeds(0, 10)``, 90/0/10): lab's GP wrapper (``fit_gpr``: ARD RBF +
   white noise, 3 restarts), Bayesian regularisation 3-30-3 (1000 epochs or mu_max), the same
   on the reference linear algebra (``BROptions(dense_reference=True)``: J formed in full,
   gamma from eigenvalues) and, for scale, scikit-learn's plain ``GaussianProcessRegressor()``.
B. **The README's recipe for a lab's own data**: ``import-data`` of the ASL Trunk September
   2024 files, then ``train --model ensemble --algorithm br --hidden 10 10 --split group``
   (five members; by default on all cores, and with ``--jobs 1``); with ``--baseline REV``
   the same command on REV's code (``git archive``), with its default BLAS threads and with one.
C. **20,000 rows, 9 inputs**: the tip of a simulated three-segment constant-curvature arm
   (:func:`three_segment_arm`), a 9-20-20-3 network, 80/10/10 split, seed 0: ``auto`` (which
   picks ``lm-subsample`` here), the same with LM's gradient stop (the paper's 1e-6),
   LM to its 1000-epoch cap (the "unlimited" reference: it does not stop earlier on these
   data), L-BFGS and Adam with their defaults; and the CPU time of an LM epoch against its
   J^T J work N_e n_params^2, which sets ``auto``'s limit.
"""

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_v] = "1"

import argparse  # noqa: E402
import platform  # noqa: E402
import resource  # noqa: E402
import shutil  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from functools import partial  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from timing import baseline_code  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # the checkout this script lives in, not another installed copy
ASL = ROOT / "data" / "third_party" / "asl-trunk" / "raw"
OUT = []


def say(line: str = "") -> None:
    OUT.append(line)
    print(line, flush=True)


def cpu(fn):
    """(result, process CPU seconds) of ``fn()``."""
    t0 = time.process_time()
    out = fn()
    return out, time.process_time() - t0


def three_segment_arm(n: int, seed: int = 0, noise_m: float = 2e-4):
    """Commands (n, 9) in [-1, 1] and tips (n, 3) m of a three-segment constant-curvature arm:
    segment s bends by curvature 6 (q_s . (cos, sin)(0, 120, 240 deg)) 1/m towards the
    direction of that sum and stretches by 15 % of the mean of its three commands (rest length
    0.1 m); Gaussian noise ``noise_m`` per coordinate."""
    rng = np.random.default_rng(seed)
    q = rng.uniform(-1, 1, (n, 9))
    T = np.tile(np.eye(4), (n, 1, 1))
    ang = np.array([0.0, 2 * np.pi / 3, 4 * np.pi / 3])
    for s in range(3):
        qs = q[:, 3 * s : 3 * s + 3]
        kx, ky = 6.0 * qs @ np.cos(ang), 6.0 * qs @ np.sin(ang)
        k, phi = np.hypot(kx, ky) + 1e-12, np.arctan2(ky, kx)
        th = k * 0.1 * (1 + 0.15 * qs.mean(axis=1))
        c, sn, cp, sp = np.cos(th), np.sin(th), np.cos(phi), np.sin(phi)
        step = np.tile(np.eye(4), (n, 1, 1))
        step[:, :3, :3] = np.stack(
            [
                np.stack([cp * cp * (c - 1) + 1, sp * cp * (c - 1), cp * sn], -1),
                np.stack([sp * cp * (c - 1), cp * cp * (1 - c) + c, sp * sn], -1),
                np.stack([-cp * sn, -sp * sn, c], -1),
            ],
            1,
        )
        step[:, :3, 3] = np.stack([cp * (1 - c) / k, sp * (1 - c) / k, sn / k], -1)
        T = T @ step
    y = T[:, :3, 3]
    return q, y + noise_m * rng.standard_normal(y.shape)


def section_splits(n_splits: int) -> None:
    from sklearn.gaussian_process import GaussianProcessRegressor

    from lab.data import read_dataset
    from lab.learn.bayes import BROptions
    from lab.learn.models import outer_split
    from lab.learn.peers import fit_gpr
    from lab.learn.studies import run_seeds
    from lab.learn.train import train

    u, y, _ = read_dataset(ROOT / "data" / "real_three_cable.csv")
    dist = lambda f, idx: 1e3 * float(np.mean(np.linalg.norm(f(u[idx]) - y[idx], axis=1)))  # noqa: E731
    say(f"## A. BR 3-30-3 and lab's GP on the ten splits of data/real_three_cable.csv ({len(u)} rows, 90/0/10)")
    say("| split | GP fit s | GP test mm | BR fit s | BR test mm | BR epochs | ms/epoch | BR/GP time "
        "| reference BR s | reference test mm | plain sklearn GP s |")  # fmt: skip
    say("|---|---|---|---|---|---|---|---|---|---|---|")
    rows = []
    for i, seed in enumerate(run_seeds(0, n_splits)):
        split = outer_split(len(u), (0.9, 0.0, 0.1), seed)
        tr, te = split.train, split.test

        def br(dense, seed=seed):
            return train(u, y, (30,), algorithm="br", ratios=(0.9, 0.0, 0.1), seed=seed,
                         options=BROptions(min_grad=0, dense_reference=dense))  # fmt: skip

        runs = {
            "gp": lambda tr=tr, seed=seed: fit_gpr(u[tr], y[tr], seed=seed),
            "br": lambda: br(False),
            "ref": lambda: br(True),
            "plain": lambda tr=tr: GaussianProcessRegressor().fit(u[tr], y[tr]),
        }
        order = list(runs)[i % 4 :] + list(runs)[: i % 4]  # who goes first rotates
        got = {name: cpu(runs[name]) for name in order}
        (gp, t_gp), (res, t_br), (ref, t_ref), (_, t_plain) = (got[k] for k in ("gp", "br", "ref", "plain"))
        assert list(res.split.test) == list(te)  # the same test rows
        e_gp, e_br = dist(gp.predict, te), 1e3 * res.errors["test"]["mean_distance_m"]
        e_ref = 1e3 * ref.errors["test"]["mean_distance_m"]
        rows.append((t_gp, e_gp, t_br, e_br, t_ref, e_ref, res.log.epochs, ref.log.epochs, t_plain))
        say(f"| {i} | {t_gp:.2f} | {e_gp:.4f} | {t_br:.2f} | {e_br:.4f} | {res.log.epochs} | "
            f"{1e3 * t_br / max(res.log.epochs, 1):.2f} | {t_br / t_gp:.2f} | {t_ref:.2f} | {e_ref:.4f} | "
            f"{t_plain:.2f} |")  # fmt: skip
    a = np.array(rows)
    say(f"| sum / mean | {a[:, 0].sum():.2f} | {a[:, 1].mean():.4f} | {a[:, 2].sum():.2f} | {a[:, 3].mean():.4f} | "
        f"{a[:, 6].mean():.0f} | {1e3 * a[:, 2].sum() / a[:, 6].sum():.2f} | {a[:, 2].sum() / a[:, 0].sum():.2f} | "
        f"{a[:, 4].sum():.2f} | {a[:, 5].mean():.4f} | {a[:, 8].sum():.2f} |")  # fmt: skip
    say(f"BR fit time / GP fit time: {a[:, 2].sum() / a[:, 0].sum():.2f} over the splits (median per split "
        f"{np.median(a[:, 2] / a[:, 0]):.2f}, worst {np.max(a[:, 2] / a[:, 0]):.2f}); splits where BR is not "
        f"slower: {int(np.sum(a[:, 2] <= a[:, 0]))} of {len(a)}")  # fmt: skip
    say(
        f"mean test error BR {a[:, 3].mean():.4f} mm vs GP {a[:, 1].mean():.4f} mm "
        f"(BR better on {int(np.sum(a[:, 3] <= a[:, 1]))} of {len(a)} splits)"
    )
    say(
        f"reference linear algebra: {a[:, 4].sum() / a[:, 2].sum():.2f} x the time; the same epochs on "
        f"{int(np.sum(a[:, 6] == a[:, 7]))} of {len(a)} splits; test error differs by at most "
        f"{np.max(np.abs(a[:, 3] - a[:, 5])):.2e} mm"
    )
    say()


def _tree_cpu(argv, env, cwd) -> tuple[float, float, str]:
    """(CPU s of the command and every process it waited for, wall s, stderr+stdout)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run(argv, env=env, cwd=cwd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode:
        raise RuntimeError(f"{' '.join(argv)} failed:\n{p.stderr[-2000:]}")
    used = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return used, wall, p.stderr + p.stdout


def section_recipe(baseline: str | None, repeats: int) -> None:
    tmp = Path(tempfile.mkdtemp(prefix="bench-training-"))
    try:
        base_env = {k: v for k, v in os.environ.items() if k not in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS",
                                                                     "MKL_NUM_THREADS", "PYTHONPATH")}  # fmt: skip
        one = {**base_env, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
        here = {**base_env, "PYTHONPATH": str(ROOT)}
        lab = [sys.executable, "-m", "lab"]
        data = tmp / "trunk.csv"
        subprocess.run([*lab, "import-data", str(ASL / "control_inputs_uniform_sep2024_669rows@419a78d.csv"),
                        "--observations", str(ASL / "steady_state_ik_y-up_200g.csv"), "--u", "u1,u2,u3,u4,u5,u6",
                        "--u-unit", "effort", "--y", "x3,y3,z3", "--y-unit", "m", "--out", str(data)],
                       env=here, check=True, capture_output=True)  # fmt: skip
        recipe = ["train", str(data), "--model", "ensemble", "--algorithm", "br", "--hidden", "10", "10",
                  "--split", "group", "--no-progress"]  # fmt: skip
        variants = {
            "this code, default threads, --jobs all cores": ({**here}, []),
            "this code, default threads, --jobs 1": ({**here}, ["--jobs", "1"]),
        }
        if baseline:
            old = {**base_env, "PYTHONPATH": str(baseline_code(baseline, tmp / "baseline"))}
            variants[f"{baseline}, default threads"] = (old, [])
            variants[f"{baseline}, OMP/OPENBLAS=1"] = ({**one, "PYTHONPATH": old["PYTHONPATH"]}, [])
        say("## B. The README's recipe: train --model ensemble --algorithm br --hidden 10 10 --split group "
            "(ASL Trunk, September 2024, 669 rows)")  # fmt: skip
        say("| code and threads | CPU s (median) | wall s | test mean distance mm |")
        say("|---|---|---|---|")
        times = {k: [] for k in variants}
        for r in range(repeats):
            for name, (env, extra) in variants.items():
                out = tmp / f"m{r}.npz"
                used, wall, text = _tree_cpu([*lab, *recipe, *extra, "--out", str(out)], env, tmp)
                test = next(line for line in text.splitlines() if line.startswith("test "))
                times[name].append((used, wall, float(test.split()[3])))
        for name, t in times.items():
            a = np.array(t)
            say(f"| {name} | {np.median(a[:, 0]):.1f} | {np.median(a[:, 1]):.1f} | {a[0, 2]:.4f} |")
        say(f"({repeats} run(s) each, interleaved; CPU of the command and its worker processes)")
        say()
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def section_large(n: int, lm_epochs: int) -> None:
    from lab.learn.gradient import AdamOptions, LBFGSOptions
    from lab.learn.lm import LMOptions
    from lab.learn.lm_subsample import LMSubsampleOptions
    from lab.learn.train import train

    u, y = three_segment_arm(n)
    say(f"## C. {n:,} rows, 9 inputs: the simulated three-segment arm, 9-20-20-3, split 80/10/10, seed 0")
    say("| algorithm | CPU s | epochs | stop | test mean distance mm | vs LM to its cap |")
    say("|---|---|---|---|---|---|")
    runs = {
        "auto": lambda: train(u, y, (20, 20), algorithm="auto", seed=0),
        "lm-subsample, LM's gradient stop 1e-6": lambda: train(
            u, y, (20, 20), algorithm="lm-subsample", seed=0, options=LMSubsampleOptions(min_grad=1e-6)
        ),
        f"lm, {lm_epochs} epochs": lambda: train(
            u, y, (20, 20), algorithm="lm", seed=0, options=LMOptions(epochs=lm_epochs)
        ),  # fmt: skip
        "lbfgs": lambda: train(u, y, (20, 20), algorithm="lbfgs", seed=0, options=LBFGSOptions()),
        "adam": lambda: train(u, y, (20, 20), algorithm="adam", seed=0, options=AdamOptions()),
    }
    got = {name: cpu(fn) for name, fn in runs.items()}
    ref = 1e3 * got[f"lm, {lm_epochs} epochs"][0].errors["test"]["mean_distance_m"]
    for name, (res, t) in got.items():
        e = 1e3 * res.errors["test"]["mean_distance_m"]
        what = f"{res.log.algorithm}" + (f" ({res.log.options['rows']} rows)" if "rows" in res.log.options else "")
        say(f"| {name}: {what} | {t:.1f} | {res.log.epochs} | {res.log.stop_reason} | {e:.4f} | {e / ref:.3f} |")
    auto = got["auto"][0].model.metadata["training"]["algorithm_choice"]
    say(f"auto's words: {auto}")
    say()
    say("LM's epoch against its J^T J work (N_e n_params^2), 9-20-20-3 on the first N training rows:")
    say("| N | N_e n_params^2 | LM s/epoch | lm-subsample s/epoch |")
    say("|---|---|---|---|")
    for rows in (500, 2000, 8000, 16000):
        k, part = 4, slice(0, rows)
        _, t_lm = cpu(partial(train, u[part], y[part], (20, 20), algorithm="lm", seed=0, epochs=k,
                              options=LMOptions(min_grad=0), ratios=(1, 0, 0)))  # fmt: skip
        _, t_sub = cpu(partial(train, u[part], y[part], (20, 20), algorithm="lm-subsample", seed=0, epochs=k,
                               ratios=(1, 0, 0)))  # fmt: skip
        say(f"| {rows} | {rows * 3 * 683**2:.2g} | {t_lm / k:.3f} | {t_sub / k:.3f} |")
    say()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", choices=("splits", "recipe", "large"))
    parser.add_argument("--quick", action="store_true", help="2 splits, 4,000 rows, LM to 100 epochs, one recipe run")
    parser.add_argument("--baseline", help="a git revision whose code also runs the README's recipe")
    parser.add_argument("--out", help="also write the printout here")
    args = parser.parse_args()
    command = "python benchmarks/bench_training.py" + "".join(f" {a}" for a in sys.argv[1:])
    say(f"command: {command}")
    say(f"machine: {platform.machine()}, {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f} at the start; "
        "one BLAS thread (OMP/OPENBLAS/MKL = 1) but where section B says otherwise")  # fmt: skip
    say()
    if args.only in (None, "splits"):
        section_splits(2 if args.quick else 10)
    if args.only in (None, "recipe"):
        section_recipe(args.baseline, 1 if args.quick else 3)
    if args.only in (None, "large"):
        section_large(4000 if args.quick else 20000, 100 if args.quick else 1000)
    say(f"load average {os.getloadavg()[0]:.1f} at the end")
    if args.out:
        Path(args.out).write_text("\n".join(OUT) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
