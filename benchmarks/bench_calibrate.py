"""Calibrated physics: the cost of the FEM parameter sensitivities dx/dtheta relative to one
static solve, how well each parameter is identified, and the time to calibrate against N.

    python benchmarks/bench_calibrate.py            # ~1 minute on 2 cores
    python benchmarks/bench_calibrate.py --n-rings 3 --n-axial 20   # the default mesh (slower)

"Real" samples come from the FEM of the shipped as-built robot
(lab/rig/defects/three-cable.toml) on the same mesh, at N scrambled-Sobol commands, with
its mocap noise (0.15 mm per axis) added; calibration starts from the nominal robot.
"""

import argparse
import time

import numpy as np
from timing import best_of

from lab.asbuilt.arm import as_built_fem, load_defects
from lab.data.designs import sobol_commands
from lab.description import load_robot
from lab.fem.solve.parameters import ParametrisedFEM
from lab.fem.solve.statics import sensitivities, solve_static
from lab.transfer import calibrate, prior_std

ap = argparse.ArgumentParser()
ap.add_argument("--n-rings", type=int, default=2)
ap.add_argument("--n-axial", type=int, default=10)
ap.add_argument("--ns", type=int, nargs="+", default=[5, 10, 30, 100])
args = ap.parse_args()
mesh = dict(n_rings=args.n_rings, n_axial=args.n_axial)

robot = load_robot("three-cable")
defects = load_defects(None, robot)
pf = ParametrisedFEM(robot, **mesh, axes="xyz")
truth_xyz = pf.layout.pack(
    defects.softness,
    defects.gradient * defects.gradient_direction_W[1:],
    [c.via_shift_m for c in defects.cables],
    defects.slack_m,
)
fem = pf.fem(truth_xyz)
print(
    f"three-cable, mesh {args.n_rings} rings x {args.n_axial} layers: {fem.n_free} unknowns, "
    f"{pf.layout.size} parameters"
)

# ---------------------------------------------------------------- sensitivity cost
u = np.array([2.0, 1.0, 0.5])
sol = solve_static(fem, u)
near = solve_static(fem, u - [0.0, 0.1, 0.0], sensitivity=True)
t_cold = best_of(lambda: solve_static(fem, u), 5)
t_warm = best_of(lambda: solve_static(fem, u, near.q + near.dq_du @ [0.0, 0.1, 0.0]), 5)
t_du = best_of(lambda: sensitivities(fem, sol.q, u))
t_dg = best_of(lambda: pf.force_derivative(truth_xyz, sol.q, u))
t_both = best_of(lambda: pf.sensitivities(truth_xyz, sol.q, u))
print("\nsensitivity cost (one equilibrium)")
print(f"  static solve from rest            {1e3 * t_cold:8.2f} ms ({sol.iterations} Newton steps)")
print(f"  static solve, warm-started        {1e3 * t_warm:8.2f} ms")
print(f"  dx/du  (statics.sensitivities)    {1e3 * t_du:8.2f} ms")
print(f"  dg/dtheta (mixed derivative)      {1e3 * t_dg:8.2f} ms")
print(
    f"  dx/du + dx/dtheta ({pf.layout.size} params)      {1e3 * t_both:8.2f} ms = "
    f"{t_both / t_cold:.2f} x a solve from rest, {t_both / t_warm:.2f} x a warm one, {t_both / t_du:.2f} x dx/du alone"
)

# ---------------------------------------------------------------- identifiability
nominal = ParametrisedFEM(robot, **mesh, axes="xyz")
u_id = sobol_commands(robot, 30, seed=1)
J = []
for ui in u_id:
    s = nominal.solve(nominal.nominal, ui)
    J.append(nominal.sensitivities(nominal.nominal, s.q, ui)[3])
J = np.concatenate(J)
prior = prior_std(nominal.layout)
post = np.sqrt(np.diag(np.linalg.inv(J.T @ J / 5e-4**2 + np.diag(1 / prior**2))))
print("\nidentifiability at the nominal, 30 Sobol commands, 0.5 mm noise (eyelet shifts along x, y and z)")
print(f"  {'parameter':<28}{'RMS |dtip/dtheta|':>18}{'prior std':>11}{'posterior std':>15}")
for name, unit, j, p0, p1 in zip(nominal.layout.names, nominal.layout.units, np.sqrt(3 * (J**2).mean(0)), prior, post):
    scale, label = (1e3, "mm/mm") if unit == "m" else (1e3, "mm/1")
    p0s, p1s = (f"{1e3 * p0:.2f} mm", f"{1e3 * p1:.3f} mm") if unit == "m" else (f"{p0:.2f}", f"{p1:.4f}")
    print(f"  {name:<28}{j * (1 if unit == 'm' else scale):>12.3g} {label:<5}{p0s:>11}{p1s:>15}")

# ---------------------------------------------------------------- calibration against N
pf_yz = ParametrisedFEM(robot, **mesh)
shift = np.array([c.via_shift_m for c in defects.cables])
truth = pf_yz.layout.pack(defects.softness, defects.gradient * defects.gradient_direction_W[1:], shift, defects.slack_m)
real_fem = as_built_fem(robot, defects, **mesh)
rng = np.random.default_rng(0)
print(f"\ncalibration against N (noise {1e3 * defects.noise_sigma_m:.2f} mm per axis, fit noise 0.5 mm)")
print(
    f"  {'N':>4}{'wall s':>8}{'s/sample':>9}{'iters':>6}{'solves':>7}{'RMS nominal':>12}{'RMS fit':>9}"
    f"{'softness':>10}{'|g|':>7}{'max shift err':>14}{'max slack err':>14}{'max|err|/std':>13}"
)
for n in args.ns:
    u_n = sobol_commands(robot, n, seed=2)
    y_n = np.array([solve_static(real_fem, ui).p_tip_W for ui in u_n])
    y_n += defects.noise_sigma_m * rng.standard_normal(y_n.shape)
    t0 = time.perf_counter()
    res = calibrate(robot, u_n, y_n, **mesh)
    wall = time.perf_counter() - t0
    err = res.theta - truth
    v = res.values
    print(
        f"  {n:>4}{wall:>8.2f}{wall / n:>9.3f}{res.iterations:>6}{res.n_solves:>7}"
        f"{1e3 * res.rms_nominal_m:>9.3f} mm{1e3 * res.rms_m:>6.3f} mm{v['softness']:>10.3f}"
        f"{np.hypot(*v['gradient']):>7.3f}{1e3 * np.abs(err[3:-3]).max():>11.3f} mm"
        f"{1e3 * np.abs(err[-3:]).max():>11.3f} mm"
        f"{np.abs(err / res.std).max():>13.2f}"
    )
print(
    f"  truth: softness {defects.softness}, |g| {defects.gradient}, slack {1e3 * defects.slack_m} mm "
    "(the data's axial eyelet shifts are 0)"
)
