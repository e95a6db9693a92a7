"""Mesh-refinement study that picks the default mesh resolution of the robot descriptions.

Solves a few commands on successively finer structured cylinder meshes and prints the
tip position's distance to the finest mesh. The default is the cheapest mesh whose tip
lies within TOL_M of the finest one for every command.

    python benchmarks/mesh_refinement.py [--robot three-cable]
"""

import argparse
import time

import numpy as np

from lab.description import load_robot
from lab.fem.model import ArmFEM
from lab.fem.solve.statics import solve_static

TOL_M = 2e-3  # 1 % of the 20 cm arm; the paper's sim tracking error is 0.5 mm, its real one 1.5 mm
MESHES = [(1, 10), (1, 20), (2, 10), (2, 20), (2, 40), (3, 20), (3, 30), (3, 40), (4, 60)]

ap = argparse.ArgumentParser()
ap.add_argument("--robot", default="three-cable")
args = ap.parse_args()
robot = load_robot(args.robot)
u_max = robot.u_max_rad
commands = [np.zeros(robot.n_cables)]
for i in range(min(3, robot.n_cables)):
    u = np.zeros(robot.n_cables)
    u[i] = u_max
    commands.append(u)
u = np.zeros(robot.n_cables)
u[1:3] = [0.5 * u_max, u_max]
commands.append(u)

tips, rows = {}, []
for n_rings, n_axial in MESHES:
    fem = ArmFEM(robot, n_rings=n_rings, n_axial=n_axial)
    t0 = time.perf_counter()
    rest = solve_static(fem, commands[0])
    tips[(n_rings, n_axial)] = np.array([rest.p_tip_W] + [solve_static(fem, u, rest.q).p_tip_W for u in commands[1:]])
    rows.append((n_rings, n_axial, fem.mesh.n_nodes, time.perf_counter() - t0))
ref = tips[MESHES[-1]]
print(
    f"{robot.name}: tip distance to the finest mesh {MESHES[-1]} over {len(commands)} commands "
    f"(rest, each cable at u_max, a mixed one)"
)
print(f"{'rings':>5} {'axial':>5} {'nodes':>6} {'max dist mm':>11} {'rest sag mm':>11} {'solve s':>8}")
chosen = None
for (n_rings, n_axial, n_nodes, t), mesh in zip(rows, MESHES):
    dist = np.linalg.norm(tips[mesh] - ref, axis=1).max()
    print(f"{n_rings:5d} {n_axial:5d} {n_nodes:6d} {1e3 * dist:11.2f} {-1e3 * tips[mesh][0, 2]:11.2f} {t:8.2f}")
    if chosen is None and dist <= TOL_M and mesh != MESHES[-1]:
        chosen = (n_rings, n_axial, n_nodes)
print(
    f"cheapest mesh within {1e3 * TOL_M:.1f} mm of the finest: n_rings={chosen[0]} n_axial={chosen[1]} "
    f"({chosen[2]} nodes); description default: n_rings={robot.n_rings} n_axial={robot.n_axial}"
)
