"""The calibration's Levenberg-Marquardt loop (lab.transfer.levenberg) against the loop it
replaced (``algorithm="marquardt"``, kept as the reference): the same optimum and chi-square
decision, no more trials or rejected trials, fewer factorisations; trials that stop early."""

import numpy as np
import pytest

from lab.data import design_commands
from lab.description import load_robot
from lab.errors import InputError
from lab.fem.solve.parameters import ParametrisedFEM
from lab.transfer import calibrate
from lab.transfer.levenberg import ALGORITHMS
from lab.transfer.samples import Samples

MESH = dict(n_rings=1, n_axial=6)


@pytest.fixture(scope="module")
def member():
    """A family member on the coarse mesh, 10 maximin samples of its settled tips (the
    reference rejects 4 of its 12 trials here: steps that push eyelets out of the body)."""
    from lab.asbuilt.family import family_member
    from lab.rig.twin import AsBuiltBody, quasi_static_tips

    robot = load_robot("three-cable")
    u = design_commands(robot, 10, "maximin", 0)
    d = family_member(robot, "random:0", **MESH)
    return robot, u, quasi_static_tips(AsBuiltBody(robot, d, **MESH), u, d.noise_sigma_m, 0)


@pytest.fixture(scope="module")
def fits(member):
    robot, u, y = member
    return {a: calibrate(robot, u, y, **MESH, algorithm=a) for a in ALGORITHMS}


def test_same_optimum_as_the_reference(fits):
    new, ref = fits["fast"], fits["marquardt"]
    assert new.algorithm == "fast" and ref.algorithm == "marquardt"
    assert new.converged and ref.converged
    # both stop within tol = 1e-3 prior std of the optimum: far inside the statistical tolerance
    assert np.all(np.abs(new.theta - ref.theta) <= 0.02 * ref.std)
    assert np.allclose(new.std, ref.std, rtol=1e-2)
    assert new.check["model_discrepancy"] == ref.check["model_discrepancy"]
    assert abs(new.rms_m - ref.rms_m) <= 1e-3 * ref.rms_m
    # the first pass is the same solves (equal to round-off: PARDISO's state differs between them)
    assert new.rms_nominal_m == pytest.approx(ref.rms_nominal_m, rel=1e-12)


def test_no_more_trials_and_fewer_factorisations(fits):
    new, ref = fits["fast"], fits["marquardt"]
    assert ref.n_rejected > 0  # the case exercises rejections
    assert new.n_rejected <= ref.n_rejected and new.n_trials <= ref.n_trials
    assert new.n_solves <= ref.n_solves and new.n_factorisations < ref.n_factorisations


def test_a_trial_stops_once_it_cannot_be_accepted(member):
    robot, u, y = member
    pf = ParametrisedFEM(robot, **MESH)
    samples = Samples(pf, u, reuse=True)
    q, tips, (dq, J) = samples.first(pf.nominal)
    solves = samples.n_solves
    step = np.zeros(pf.layout.size)
    step[0] = 0.1
    start = q + dq @ step
    limit = 0.5 * float(np.sum((tips - y) ** 2))  # half the misfit at the nominal: out of reach
    fresh = pf.n_factorisations  # (the sensitivities' own factorisations)
    assert samples.solve(pf.nominal + step, start, y=y, limit=limit) is None
    assert samples.n_solves - solves < len(u) and samples.misfit_m2 >= limit
    assert pf.n_factorisations == fresh  # a trial stopped early factorised nothing for sensitivities
    got = samples.solve(pf.nominal + step, start, y=y, limit=np.inf, order=np.arange(len(u))[::-1])
    assert len(got) == 4 and got[3].shape == (len(u), 3, pf.layout.size)


def test_unknown_algorithm_is_refused(member):
    robot, u, y = member
    with pytest.raises(InputError, match="algorithm"):
        calibrate(robot, u, y, **MESH, algorithm="gauss-newton")


def test_another_robot_of_the_same_description_repeats_no_first_pass(member, fits):
    from lab.transfer import samples

    robot, u, y = member
    y2 = y + 1e-4 * np.random.default_rng(1).standard_normal(y.shape)  # another robot's tips
    samples._FIRST.clear()
    alone = calibrate(robot, u, y2, **MESH)
    calibrate(robot, u, y, **MESH)  # remembers its first pass
    after = calibrate(robot, u, y2, **MESH)
    assert after.n_solves == alone.n_solves - len(u)  # the pass's solves saved
    assert after.n_factorisations < alone.n_factorisations
    assert np.array_equal(after.theta, alone.theta) and np.array_equal(after.residuals_m, alone.residuals_m)
    assert after.rms_nominal_m == alone.rms_nominal_m


def test_a_worker_starts_from_the_first_pass_its_parent_remembers(member):
    """What :func:`lab.transfer.family_recovery` hands its workers: the first pass of another
    process, remembered here, saves its solves; None changes nothing."""
    from lab.transfer import samples

    robot, u, y = member
    samples._FIRST.clear()
    alone = calibrate(robot, u, y, **MESH)
    entry = samples.remembered_first_pass()
    samples._FIRST.clear()
    samples.remember_first_pass(None)
    assert samples.remembered_first_pass() is None
    samples.remember_first_pass(entry)
    handed = calibrate(robot, u, y, **MESH)
    assert handed.n_solves == alone.n_solves - len(u)
    assert np.array_equal(handed.theta, alone.theta)
