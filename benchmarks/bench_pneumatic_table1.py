"""Table I on the pneumatic arm: sim/sim, real/real and with <= 30 real samples, over the pneumatic family.

    python benchmarks/bench_pneumatic_table1.py --members 0-9 --jobs 2 --skip-calibrated \\
        --txt benchmarks/bench_pneumatic_table1.txt

Three studies on ``lab/robots/pneumatic-arm.toml`` (inputs: three chamber pressures, Pa),
each one a chain of ``python -m lab`` commands run as subprocesses (so every file carries the
command that made it), every output cached under ``data/pneumatic_arm/`` and skipped when
present, so an interrupted run resumes where it stopped and a later run adds members:

1. **Sim/sim**: ``simulate --grid 7`` (343 commands, ``sim_grid7.csv``), ``train`` (seed 0,
   ``model_sim_grid7.npz``); the circle, square and rose fitted into the workspace of that
   dataset (:func:`lab.control.fitted_shape`, ``--n-points`` targets each, one after the other
   in ``shapes/sim.csv``) and tracked on the nominal FEM (``--rig sim``) through the
   network and, as the model-based baseline, through Soft IK (``--soft-ik``: the IK through
   the FEM itself) on the same targets: mean error per shape and the IK time per target.
2. **Real/real** on member K of the pneumatic family (``--rig twin:pneumatic:K``, an
   *emulated as-built robot (pneumatic family)*): a 308-command scrambled-Sobol design (seed 0)
   captured by waiting (``real308_memberK.csv``), a network trained on it, the three shapes
   tracked on the same member.
3. **<= 30 real samples**: a 30-command Sobol design with another seed (1) captured on the
   member (``real30_memberK.csv``); ``transfer`` with ``real-only`` (the baseline), ``residual``
   and ``finetune`` (from the sim network) and, unless ``--skip-calibrated`` and for the
   members of ``--calibrated-members``, ``calibrated`` (the FEM fitted to the 30 samples, the
   grid re-simulated on it); each model tracked on the member.

On a member every method tracks the **same targets**: the shapes fitted to the member's own
30-sample capture (``shapes/memberK.csv``), the data every method on it has (the
members' workspaces differ by millimetres: each sags differently). The three shapes are
tracked in one ``track`` run per robot and method (settled at every target, so one run is
three runs back to back without two process starts), its JSON ``track/COND.json`` split
into the shapes by target index; ``results.csv`` (one row per robot, method and
shape) is rebuilt from them after every step. The printout (``--txt``) lists what ran and
what did not.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import platform
import shlex
import subprocess
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

ROBOT = "pneumatic-arm"
SHAPES = ("circle", "square", "rose")
CHEAP = ("real-only", "residual", "finetune")
METHOD_ORDER = ("real308", *CHEAP, "calibrated")
LABEL = "emulated as-built robot (pneumatic family)"
TARGETS_CM = {"sim/sim": 0.05, "real/real": 0.15, "<= 30 real": 0.25}
ENV = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
ENV["PYTHONPATH"] = str(Path(__file__).resolve().parents[1]) + os.pathsep + ENV.get("PYTHONPATH", "")

_print_lock = threading.Lock()
T0 = time.perf_counter()


def say(line: str) -> None:
    with _print_lock:
        print(f"[{time.perf_counter() - T0:7.0f} s] {line}", flush=True)


def lab(args: list[str], out: Path, log_dir: Path) -> bool:
    """Run ``python -m lab ARGS`` unless ``out`` exists; its output to ``log_dir``. True if ``out`` exists after."""
    if out.exists():
        return True
    log_dir.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    with open(log_dir / f"{out.name}.log", "w") as log:
        rc = subprocess.run(
            [sys.executable, "-m", "lab", *args], env=ENV, stdout=log, stderr=subprocess.STDOUT, check=False
        ).returncode
    status = "done" if rc == 0 else f"FAILED (exit {rc})"
    say(f"{status} in {time.perf_counter() - t0:.0f} s: python -m lab {shlex.join(args)}")
    return rc == 0 and out.exists()


def member_list(text: str) -> list[int]:
    out: list[int] = []
    for part in text.split(","):
        a, _, b = part.partition("-")
        a, b = int(a), int(b or a)
        out += list(range(a, b + 1) if a <= b else range(a, b - 1, -1))  # 9-5: in that order
    return out


def write_shapes(data_csv: Path, path: Path, n_points: int) -> Path:
    """The three shapes fitted to ``data_csv``'s tips, ``n_points`` each, one after the other
    (circle, square, rose) in one trajectory CSV ``path`` (kept if present)."""
    from lab.control import fitted_shape
    from lab.control.trajectories import write_trajectory_csv
    from lab.data import read_dataset

    if not path.exists():
        _, y, _ = read_dataset(data_csv)
        path.parent.mkdir(parents=True, exist_ok=True)
        write_trajectory_csv(path, np.vstack([fitted_shape(s, y[:, :3], n_points=n_points) for s in SHAPES]))
    return path


class Study:
    def __init__(self, args):
        self.a = args
        self.d = args.dir
        self.logs = self.d / "logs"
        self.sim_csv = self.d / "sim_grid7.csv"
        self.sim_model = self.d / "model_sim_grid7.npz"
        self.lock = threading.Lock()

    def track(self, cond: str, rig: str, how: list[str], shapes: Path) -> None:
        """Track the three shapes (one run, ``shapes``) on ``rig``: ``track/COND.json``."""
        out = self.d / "track" / f"{cond}.json"
        args = ["track", *how, "--robot", ROBOT, "--rig", rig, "--trajectory", str(shapes), "--out", str(out)]
        lab(args, out, self.logs)
        self.write_results()

    # -- 1. sim/sim ---------------------------------------------------------------------------
    def sim(self) -> None:
        grid = ["simulate", "--robot", ROBOT, "--grid", "7", "--jobs", str(self.a.jobs), "--no-progress"]
        if not lab([*grid, "--out", str(self.sim_csv)], self.sim_csv, self.logs):
            return
        if not lab(
            ["train", str(self.sim_csv), "--seed", "0", "--out", str(self.sim_model)], self.sim_model, self.logs
        ):
            return
        shapes = write_shapes(self.sim_csv, self.d / "shapes" / "sim.csv", self.a.n_points)
        self.track("sim_network", "sim", ["--model", str(self.sim_model)], shapes)
        if not self.a.skip_soft_ik:  # the FEM in the IK loop: every E-th target of each shape
            sub = self.d / "shapes" / f"sim_every{self.a.soft_ik_every}.csv"
            if not sub.exists():
                from lab.control.trajectories import load_trajectory, write_trajectory_csv

                pts = load_trajectory(str(shapes))
                n = len(pts) // len(SHAPES)
                write_trajectory_csv(sub, pts[[i for i in range(len(pts)) if (i % n) % self.a.soft_ik_every == 0]])
            self.track("sim_softik", "sim", ["--soft-ik"], sub)

    # -- 2. and 3. on member k ----------------------------------------------------------------
    def capture(self, k: int, n: int, seed: int) -> Path | None:
        out = self.d / f"real{n}_member{k}.csv"
        args = ["capture", "--rig", f"twin:pneumatic:{k}", "--robot", ROBOT, "--sobol", str(n), "--seed", str(seed)]
        lock = self.d / f"real{n}_member{k}.journal.csv.lock"
        for _ in range(900):  # another run of this script is capturing it: wait for it (15 min at most)
            if out.exists() or not lock.exists():
                break
            time.sleep(1)
        return out if lab([*args, "--no-progress", "--out", str(out)], out, self.logs) else None

    def member_shapes(self, k: int) -> Path | None:
        real30 = self.capture(k, 30, 1)
        return None if real30 is None else write_shapes(real30, self.d / "shapes" / f"member{k}.csv", self.a.n_points)

    def transfer(self, k: int, methods) -> None:
        shapes = self.member_shapes(k)
        if shapes is None:
            return
        real30 = self.d / f"real30_member{k}.csv"
        for method in methods:
            model = self.d / "models" / f"{method}_member{k}.npz"
            src = (
                ["--sim", str(self.sim_csv), "--jobs", str(self.a.calibrated_jobs)]
                if method == "calibrated"
                else ([] if method == "real-only" else ["--sim-model", str(self.sim_model)])
            )
            args = ["transfer", "--method", method, *src, "--real", str(real30), "--robot", ROBOT, "--seed", "0"]
            if lab([*args, "--out", str(model)], model, self.logs):
                self.track(f"member{k}_{method}", f"twin:pneumatic:{k}", ["--model", str(model)], shapes)

    def real308(self, k: int) -> None:
        real = self.capture(k, 308, 0)
        if real is None:
            return
        model = self.d / "models" / f"real308_member{k}.npz"
        if not lab(["train", str(real), "--seed", "0", "--out", str(model)], model, self.logs):
            return
        shapes = self.member_shapes(k)
        if shapes is not None:
            self.track(f"member{k}_real308", f"twin:pneumatic:{k}", ["--model", str(model)], shapes)

    # -- results --------------------------------------------------------------------------------
    def write_results(self) -> list[dict]:
        rows = []
        for f in sorted((self.d / "track").glob("*.json")):
            r = json.loads(f.read_text())
            robot, _, method = f.stem.partition("_")
            n = len(r["targets"]) // len(SHAPES)
            err = np.asarray(r["errors_m"], float)
            for i, shape in enumerate(SHAPES):
                part = slice(i * n, (i + 1) * n)
                rows.append(
                    {
                        "robot": "nominal FEM" if robot == "sim" else f"twin:pneumatic:{robot.removeprefix('member')}",
                        "method": {"network": "sim network", "softik": "Soft IK"}.get(method, method),
                        "shape": shape,
                        "n_targets": n,
                        "mean_error_m": float(np.mean(err[part])),
                        "max_error_m": float(np.max(err[part])),
                        "n_unreachable": int(np.sum(~np.asarray(r["reachable"][part], bool))),
                        "n_not_settled": int(np.sum(~np.asarray(r["settled"][part], bool))),
                        "ik_per_target_mean_s": r["timings"]["ik_total_s"] / len(err),
                        "track_file": str(f),
                    }
                )
        soft, net = self.d / "track" / "sim_softik.json", self.d / "track" / "sim_network.json"
        if soft.exists() and net.exists():  # the network's errors at Soft IK's targets, from its own run
            rs, rn = json.loads(soft.read_text()), json.loads(net.read_text())
            tn = np.asarray(rn["targets"])
            idx = [int(np.argmin(np.linalg.norm(tn - t, axis=1))) for t in np.asarray(rs["targets"])]
            err, n = np.asarray(rn["errors_m"])[idx], len(idx) // len(SHAPES)
            for i, shape in enumerate(SHAPES):
                part = slice(i * n, (i + 1) * n)
                rows.append(
                    {
                        **next(r for r in rows if r["method"] == "sim network" and r["shape"] == shape),
                        "method": "sim network at Soft IK's targets",
                        "n_targets": n,
                        "mean_error_m": float(np.mean(err[part])),
                        "max_error_m": float(np.max(err[part])),
                        "n_unreachable": int(np.sum(~np.asarray(rn["reachable"], bool)[idx][part])),
                        "n_not_settled": int(np.sum(~np.asarray(rn["settled"], bool)[idx][part])),
                    }
                )
        with self.lock:
            path = self.d / "results.csv"
            tmp = path.with_suffix(".csv.tmp")
            with open(tmp, "w", newline="") as fh:
                w = csv.DictWriter(fh, list(rows[0]) if rows else ["robot"], lineterminator="\n")
                w.writeheader()
                w.writerows(rows)
            tmp.replace(path)
        return rows


def report(rows: list[dict], args, wall_s: float) -> str:
    """The printout: per shape, per member, per method, in cm, and what did not run."""
    cm = 100.0
    lines = [
        f"# python benchmarks/bench_pneumatic_table1.py {shlex.join(sys.argv[1:])}",
        f"# machine: {platform.node()} {platform.machine()}, {os.cpu_count()} CPUs shared with other work; "
        f"python {platform.python_version()}; this invocation's wall time {wall_s / 60:.1f} min",
        f"# robot {ROBOT}; targets per shape {args.n_points}; all errors are mean 3-D distances from the target, cm",
        "",
    ]
    by = {}
    for r in rows:
        by.setdefault((r["robot"], r["method"]), {})[r["shape"]] = r

    def mean(d):
        return np.mean([d[s]["mean_error_m"] for s in SHAPES]) * cm

    # 1. sim/sim
    lines.append("## 1. Sim/sim: trained on the 343-command FEM grid, tracked on the nominal FEM")
    lines.append(
        f"{'IK through':<34}" + "".join(f"{s:>9}" for s in SHAPES) + f"{'mean':>9}{'max':>9}"
        f"{'IK s/target':>13}{'unreachable':>13}"
    )
    t_net = None
    for method in ("sim network", "sim network at Soft IK's targets", "Soft IK"):
        d = by.get(("nominal FEM", method), {})
        if set(d) != set(SHAPES):
            lines.append(f"{method:<34} not run (shapes done: {sorted(d) or 'none'})")
            continue
        t = np.mean([d[s]["ik_per_target_mean_s"] for s in SHAPES])
        t_net = t if method == "sim network" else t_net
        lines.append(
            f"{method:<34}"
            + "".join(f"{d[s]['mean_error_m'] * cm:9.4f}" for s in SHAPES)
            + f"{mean(d):9.4f}{max(d[s]['max_error_m'] for s in SHAPES) * cm:9.4f}{t:13.4f}"
            f"{sum(d[s]['n_unreachable'] for s in SHAPES):13d}"
        )
        if method == "Soft IK" and t_net:
            lines.append(f"  Soft IK's IK time per target / the network's, same run: {t / t_net:.0f}x")
    net = by.get(("nominal FEM", "sim network"))
    if net and set(net) == set(SHAPES):
        t = np.asarray(json.loads(Path(net["circle"]["track_file"]).read_text())["targets"])
        n = len(t) // len(SHAPES)
        lines.append(
            f"  shapes: circle {np.ptp(t[:n, 1]) * 1e3:.2f} mm across, centre at z = {t[:, 2].mean() * 1e3:.1f} mm"
        )
    lines.append(f"  (target: mean <= {TARGETS_CM['sim/sim']} cm with the network)")
    lines.append("")

    # 2./3. members
    members = sorted({r["robot"] for r in rows if r["robot"] != "nominal FEM"}, key=lambda s: int(s.rsplit(":", 1)[1]))
    lines.append(
        f"## 2./3. Members of twin:pneumatic:K, each an {LABEL}; targets fitted to the member's own 30-sample capture"
    )
    lines.append("mean over circle, square, rose per robot and method (cm); '-' = not run")
    lines.append(f"{'robot':<18}" + "".join(f"{m:>12}" for m in METHOD_ORDER) + f"{'circle mm':>11}{'tip z mm':>10}")
    per_method: dict[str, list[float]] = {m: [] for m in METHOD_ORDER}
    for rb in members:
        cells = []
        for m in METHOD_ORDER:
            d = by.get((rb, m), {})
            if set(d) == set(SHAPES):
                per_method[m].append(mean(d))
                cells.append(f"{mean(d):12.4f}")
            else:
                cells.append(f"{'-':>12}")
        t = np.asarray(
            json.loads(
                Path(next(iter(next(d for (r, _), d in by.items() if r == rb).values()))["track_file"]).read_text()
            )["targets"]
        )
        n = len(t) // len(SHAPES)  # the circle's diameter and the shapes' centre height: the member's workspace
        lines.append(f"{rb:<18}" + "".join(cells) + f"{np.ptp(t[:n, 1]) * 1e3:11.2f}{t[:, 2].mean() * 1e3:10.1f}")
    lines.append(
        f"{'mean over robots':<18}" + "".join(f"{np.mean(v):12.4f}" if v else f"{'-':>12}" for v in per_method.values())
    )
    lines.append(f"{'robots':<18}" + "".join(f"{len(v):12d}" for v in per_method.values()))
    lines.append(
        f"{'worst robot':<18}" + "".join(f"{np.max(v):12.4f}" if v else f"{'-':>12}" for v in per_method.values())
    )
    both = [rb for rb in members if all(set(by.get((rb, m), {})) == set(SHAPES) for m in ("real308", *CHEAP))]
    if both:  # paired: the same robots for every method
        lines.append(
            f"{'same robots':<18}"
            + "".join(
                f"{np.mean([mean(by[(rb, m)]) for rb in both]):12.4f}" if m != "calibrated" else f"{'':>12}"
                for m in METHOD_ORDER
            )
            + f"   (the {len(both)} robots with real308 and every <= 30-sample method)"
        )
    lines.append("")
    lines.append("per shape, mean over the robots that ran the method (cm):")
    lines.append(f"{'method':<12}" + "".join(f"{s:>9}" for s in SHAPES) + f"{'unreachable':>13}{'not settled':>13}")
    for m in METHOD_ORDER:
        ds = [by[(rb, m)] for rb in members if set(by.get((rb, m), {})) == set(SHAPES)]
        if ds:
            lines.append(
                f"{m:<12}"
                + "".join(f"{np.mean([d[s]['mean_error_m'] for d in ds]) * cm:9.4f}" for s in SHAPES)
                + f"{sum(d[s]['n_unreachable'] for d in ds for s in SHAPES):13d}"
                + f"{sum(d[s]['n_not_settled'] for d in ds for s in SHAPES):13d}"
            )
    lines.append(
        f"  targets: real/real (real308) <= {TARGETS_CM['real/real']} cm; best of the <= 30-sample methods "
        f"<= {TARGETS_CM['<= 30 real']} cm (real-only is the baseline)"
    )
    asked = member_list(args.members)
    missing = {
        m: [k for k in asked if f"twin:pneumatic:{k}" not in {rb for (rb, mm) in by if mm == m}] for m in METHOD_ORDER
    }
    lines.append("")
    lines.append(
        "not run (of --members "
        + args.members
        + "): "
        + "; ".join(f"{m}: {','.join(map(str, v)) if v else 'none'}" for m, v in missing.items())
    )
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--members", default="0-9", help="members of twin:pneumatic, in order (0-9, 9-5, 0,2,5-7)")
    ap.add_argument("--jobs", type=int, default=2, help="members worked on at once (and simulate's workers)")
    ap.add_argument(
        "--stages",
        nargs="+",
        default=["sim", "transfer", "real308", "calibrated"],
        choices=["sim", "transfer", "real308", "calibrated"],
    )
    ap.add_argument("--skip-calibrated", action="store_true", help="no calibrated transfer (the expensive one)")
    ap.add_argument("--calibrated-members", default=None, help="members for calibrated (default: --members)")
    ap.add_argument("--calibrated-jobs", type=int, default=1, help="calibrated's re-simulation workers")
    ap.add_argument("--skip-soft-ik", action="store_true")
    ap.add_argument("--soft-ik-every", type=int, default=4, help="Soft IK on every E-th target of each shape")
    ap.add_argument("--n-points", type=int, default=16, help="targets per shape")
    ap.add_argument("--dir", type=Path, default=Path("data/pneumatic_arm"))
    ap.add_argument("--txt", type=Path, help="also write the printout here")
    ap.add_argument("--report-only", action="store_true", help="only rebuild results.csv and the printout")
    args = ap.parse_args()
    study = Study(args)
    members = member_list(args.members)
    if not args.report_only:
        if "sim" in args.stages:
            study.sim()
        with ThreadPoolExecutor(max_workers=args.jobs) as pool:
            if "transfer" in args.stages:
                list(pool.map(lambda k: study.transfer(k, CHEAP), members))
            if "real308" in args.stages:
                list(pool.map(study.real308, members))
            if "calibrated" in args.stages and not args.skip_calibrated:
                cal = member_list(args.calibrated_members) if args.calibrated_members else members
                list(pool.map(lambda k: study.transfer(k, ("calibrated",)), cal))
    rows = study.write_results()
    text = report(rows, args, time.perf_counter() - T0)
    print(text)
    if args.txt:
        args.txt.write_text(text)


if __name__ == "__main__":
    main()
