"""Where calibrated physics loses on the foam family: one out-of-class defect removed at a time.

    python benchmarks/bench_foam_attribution.py --robots 3    # ~40 min on 1 core

For foam members 0..K-1 (``twin:foam:SEED``), the member as drawn and four variants, each
with one group of the defects that ``calibrate`` has no parameter for taken out:
``no tilt/frame`` (the base level and the mocap registered exactly: what fitting the mount
tilt and the frame registration could win at best), ``neo-Hookean`` (the nominal law instead
of the hyperfoam one, same softness and gradient), ``stiff cables`` (inextensible), and
``nominal mesh`` (the description's 3 x 20 instead of the finer one). Each variant is sampled
at N maximin commands (settled tips plus its mocap noise), calibrated (and the 7-level
lattice re-simulated and learnt, as ``transfer-curve --methods calibrated``), and scored as
the curve does: model error on held-out random commands and Table I tracking (24 targets
per shape). Also printed: ``finetune`` at the same N on the member as drawn, the
data-driven peer. Ratios are within this run.
"""

import argparse
import copy
import time

import numpy as np

from lab.asbuilt.family import family_member
from lab.asbuilt.parse import parse_defects
from lab.data.designs import design_commands, grid_commands
from lab.description import load_robot
from lab.learn import load_model
from lab.rig.twin import AsBuiltBody, quasi_static_tips
from lab.studies.transfer_study import evaluate_model, make_methods, random_safe_commands
from lab.transfer.calibrated import calibrated_model


def variants(source: dict) -> dict:
    def no_frame(d):
        d.pop("mount", None)
        for k in ("frame_rotation_deg", "frame_rotation_axis", "frame_offset_m"):
            d["mocap"].pop(k, None)

    def neo(d):
        for k in ("law", "hyperfoam_mu_pa", "hyperfoam_alpha", "hyperfoam_beta"):
            d["material"].pop(k, None)

    def stiff(d):
        for c in d["cables"]:
            c.pop("stiffness_n_per_m", None)

    def nominal_mesh(d):
        d.pop("emulator", None)

    out = {"as drawn": copy.deepcopy(source)}
    for name, edit in (
        ("no tilt/frame", no_frame),
        ("neo-Hookean", neo),
        ("stiff cables", stiff),
        ("nominal mesh", nominal_mesh),
    ):
        d = copy.deepcopy(source)
        edit(d)
        out[name] = d
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", type=int, default=3, help="foam members 0..K-1")
    ap.add_argument("--seeds", type=int, nargs="+", help="these foam members instead of 0..K-1")
    ap.add_argument("--n", type=int, default=30)
    ap.add_argument("--n-test", type=int, default=50)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--sim-model", default="data/model_sim_three_cable.npz")
    ap.add_argument("--variants", nargs="+", help="only these variants (default: all)")
    args = ap.parse_args()
    robot = load_robot("three-cable")
    sim_model = load_model(args.sim_model)
    u = design_commands(robot, args.n, "maximin", args.seed)
    u_test = random_safe_commands(robot, args.n_test, args.seed + 1)
    u_sim = grid_commands(robot, 7)
    u_sim = u_sim[robot.is_safe(u_sim)]
    finetune = make_methods(sim_model, ["finetune"], seed=args.seed)["finetune"]
    print(f"three-cable, N = {args.n} maximin samples, {args.n_test} held-out commands, 24 targets per shape")
    print(f"{'robot':>7} {'variant':>14} {'tracking cm':>11} {'model mm':>9} {'fit RMS mm':>10} {'s':>5}")
    results: dict = {}
    for k in args.seeds or range(args.robots):
        source = family_member(robot, f"foam:{k}").source
        for name, data in variants(source).items():
            if args.variants and name not in args.variants and name != "as drawn":
                continue
            t0 = time.perf_counter()
            d = parse_defects(data, robot, f"foam:{k} {name}")
            body = AsBuiltBody(robot, d)
            y = quasi_static_tips(body, u, d.noise_sigma_m, args.seed)
            tips_test = quasi_static_tips(body, u_test)
            model = calibrated_model(robot, u, y, u_sim, seed=args.seed)
            ev = evaluate_model(model, body, u_test, tips_test, n_points=24)
            fit = model.metadata["transfer"]["calibration"]["rms_m"]
            results.setdefault(name, []).append((ev["tracking_mean_m"], ev["model_error_m"]))
            print(
                f"{'foam:' + str(k):>7} {name:>14} {100 * ev['tracking_mean_m']:11.3f} "
                f"{1e3 * ev['model_error_m']:9.2f} {1e3 * fit:10.3f} {time.perf_counter() - t0:5.0f}",
                flush=True,
            )
            if name == "as drawn":
                ft = evaluate_model(finetune(u, y), body, u_test, tips_test, n_points=24)
                results.setdefault("finetune, as drawn", []).append((ft["tracking_mean_m"], ft["model_error_m"]))
                print(
                    f"{'foam:' + str(k):>7} {'finetune':>14} {100 * ft['tracking_mean_m']:11.3f} "
                    f"{1e3 * ft['model_error_m']:9.2f}",
                    flush=True,
                )
    print("\nmean over the robots (calibrated unless named):")
    base = np.mean([t for t, _ in results["as drawn"]])
    for name, v in results.items():
        t, e = np.mean(v, axis=0)
        print(f"  {name:>18}: tracking {100 * t:.3f} cm ({t / base:.2f}x as drawn), model error {1e3 * e:.2f} mm")


if __name__ == "__main__":
    main()
