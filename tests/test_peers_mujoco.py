"""The MuJoCo model of the arm (lab.peers.mujoco_arm): same mesh, cables, and gravity sag.

mujoco is a pinned dependency (environment.txt): these tests fail, not skip, without it.
"""

import mujoco
import numpy as np
import pytest

from lab.errors import InputError
from lab.fem.model import ArmFEM
from lab.fem.solve.statics import solve_static
from lab.peers import mujoco_arm

#: Settled MuJoCo tip vs our rest tip on the (2, 10) mesh, m. Both use the same mesh, the same
#: E, nu and the same lumped masses, and both laws reduce to the same Hooke law at small
#: strain. At rest the largest Green strain in our solution is 2.2 %, where a neo-Hookean and
#: a Saint Venant-Kirchhoff solid differ by at most ~(3/2) eps ~ 3 % in stress, i.e. <= 0.3 mm
#: of the 9.7 mm sag (with the cables slack the two sags differ by only 0.03 mm:
#: benchmarks/bench_peers.py). The cables add the rest: the top one holds ~0.12 N at rest, and
#: MuJoCo's via sites follow one node each (moment arm 10 or 20 mm instead of 15 on this
#: mesh). 1 mm is ~10 % of the sag: an arm without gravity, or with a wrong modulus, density
#: or mass lumping (sag off by > 10 %), fails. Measured: 0.50 mm.
REST_TIP_TOL_M = 1.0e-3


@pytest.fixture(scope="module")
def fem(three_cable):
    return ArmFEM(three_cable, n_rings=2, n_axial=10)


@pytest.fixture(scope="module")
def arm(fem):
    return mujoco_arm(fem)


def test_mujoco_is_installed():
    assert mujoco.__version__ == "4.0.0"  # the pin of environment.txt


def test_model_has_our_mesh_and_cables(arm, fem):
    m = arm.model
    free_nodes = len(fem.free_dofs) // 3
    assert m.nbody - 1 == free_nodes == len(arm.free_nodes)  # one body per free node (+ world)
    assert m.nv == fem.n_free  # three slide joints per free node
    assert m.nflex == 1 and m.nflexvert == fem.mesh.n_nodes and m.nflexelem == len(fem.mesh.tets)
    assert m.ntendon == len(fem.cables) == 3
    # Lumped masses equal ours, node by node.
    np.testing.assert_allclose(m.body_mass[1:], fem.m_node_kg[arm.free_nodes], rtol=1e-12)
    np.testing.assert_allclose(m.opt.gravity, fem.robot.gravity_m_s2)


def test_tendons_start_at_our_rest_lengths(arm, fem):
    d = arm.new_data()
    L0 = np.array([c.L0_m for c in fem.cables])
    np.testing.assert_allclose(arm.tendon_lengths(d), L0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(arm.node_positions(d), fem.X_W)


def test_rest_length_follows_the_command_and_the_spring_is_tension_only(fem):
    arm = mujoco_arm(fem)  # its own model: set_command changes the model
    d = arm.new_data()
    r, k = fem.robot.spool_radius_m, fem.robot.cable_stiffness_n_m
    L0 = np.array([c.L0_m for c in fem.cables])
    u = np.array([0.2, 0.0, -0.3])  # pulled, neutral, paid out
    arm.set_command(u)
    np.testing.assert_allclose(arm.model.tendon_lengthspring[:, 1], L0 - r * u, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(arm.model.tendon_lengthspring[:, 0], 0.0)
    mujoco.mj_forward(arm.model, d)
    # At the rest shape the flex is unstrained and nothing moves, so the passive force is the
    # cables' alone: only cable 0 (stretched by r u_0) pulls, with tension k r u_0 along its
    # length gradient; cable 2 is slack (no force, not a push).
    ten_J = np.zeros((arm.model.ntendon, arm.model.nv))
    m = arm.model  # MuJoCo 4 keeps the sparsity pattern of ten_J in the model
    mujoco.mju_sparse2dense(ten_J, d.ten_J, m.ten_J_rownnz, m.ten_J_rowadr, m.ten_J_colind)
    expected = -(k * r * u[0]) * ten_J[0]
    np.testing.assert_allclose(d.qfrc_passive, expected, rtol=1e-9, atol=1e-12)
    arm.set_command(np.array([0.0, 0.0, -0.3]))
    mujoco.mj_forward(arm.model, d)
    assert np.abs(d.qfrc_passive).max() < 1e-12


def test_hangs_under_gravity_near_our_rest_sag(arm, fem):
    rest = solve_static(fem, np.zeros(3))
    d = arm.new_data()
    res = arm.settle(d, v_tol_m_s=1e-4, hold_s=0.1, max_time_s=5.0)
    assert res.status == "settled", res
    tip = arm.tip(d)
    sag_m = -rest.p_tip_W[2]
    assert 5e-3 < sag_m < 20e-3  # the arm does sag (9.7 mm): the tolerance is ~10 % of it
    assert np.linalg.norm(tip - rest.p_tip_W) < REST_TIP_TOL_M, (tip, rest.p_tip_W)


def test_bad_settings_raise(fem):
    with pytest.raises(InputError, match="timestep_s"):
        mujoco_arm(fem, timestep_s=0.0)
    with pytest.raises(InputError, match="integrator"):
        mujoco_arm(fem, integrator="implicitfast")
    arm = mujoco_arm(fem)
    with pytest.raises(InputError, match="u_motor"):
        arm.set_command(np.zeros(2))


def test_settle_reports_divergence_and_timeouts(fem):
    # Explicit Euler at 1 ms steps cannot carry the flex damping: MuJoCo flags a bad qacc at once.
    arm = mujoco_arm(fem, integrator="Euler", timestep_s=1e-3)
    res = arm.settle(arm.new_data(), max_time_s=1.0)
    assert res.status == "unstable" and res.sim_time_s < 0.1
    # 50 ms is far too short for the arm to come to rest (it still falls at ~0.1 m/s).
    arm = mujoco_arm(fem)
    res = arm.settle(arm.new_data(), max_time_s=0.05)
    assert res.status == "not_settled" and res.max_speed_m_s > 1e-2
