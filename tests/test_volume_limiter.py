"""The line search's volume limiter keeps foam solves out of the PSD projection.

From rest, a foam arm's first full Newton step crushed the elements beside the eyelets to
about half their volume, where the hyperfoam's Hessian is indefinite, and the next steps
were projected. ``statics.MIN_VOLUME_RATIO`` rejects such a trial; the equilibrium is the
same (the limiter only shortens steps), and the projection is no longer needed.
"""

import numpy as np
import pytest

from lab.asbuilt.arm import as_built_fem
from lab.asbuilt.family import family_member
from lab.fem.solve import statics
from lab.fem.solve.statics import solve_static


@pytest.fixture(scope="module")
def foam_fem(three_cable):
    return as_built_fem(three_cable, family_member(three_cable, "foam:0"))


COMMANDS = [[3.0, 1.0, 0.0], [0.0, 3.0, 2.0], [1.0, 0.0, 3.0]]  # rad: each took 4-5 projected steps without the limiter


def test_foam_solves_need_no_projection_and_reach_the_same_equilibrium(foam_fem, monkeypatch):
    limited = [solve_static(foam_fem, u) for u in COMMANDS]
    assert [s.projected_steps for s in limited] == [0] * len(COMMANDS)
    monkeypatch.setattr(statics, "MIN_VOLUME_RATIO", 0.0)  # the line search without the limiter
    free = [solve_static(foam_fem, u) for u in COMMANDS]
    assert sum(s.projected_steps for s in free) > 0  # what the limiter prevents
    for a, b in zip(limited, free):
        assert np.max(np.abs(a.p_tip_W - b.p_tip_W)) < 1e-8  # m: the same equilibrium


def test_volume_ratio_is_det_F(foam_fem):
    x = foam_fem.to_nodes(foam_fem.rest_q())
    assert np.allclose(foam_fem.elastic.volume_ratio(x), 1.0, atol=1e-12)
    x = x + np.random.default_rng(0).normal(scale=1e-3, size=x.shape)
    J = foam_fem.elastic.volume_ratio(x)
    assert np.allclose(J, np.linalg.det(foam_fem.elastic.deformation_gradient(x)), rtol=1e-12, atol=1e-14)
    assert np.ptp(J) > 0.01  # the noise changed the volumes: a real comparison


def test_compiled_volume_ratio_is_the_reference(foam_fem):
    from lab.fem.kernels import compiled_law

    q = foam_fem.rest_q() + np.random.default_rng(1).normal(scale=1e-3, size=foam_fem.n_free)
    x = foam_fem.to_nodes(q)
    a, b = foam_fem.mesh.tets[-1, :2]  # a tet at the tip (free nodes): collapsed onto an edge
    x[a] = x[b]
    q = foam_fem.to_free(x)
    reference = foam_fem.elastic.volume_ratio(x)
    compiled = compiled_law(foam_fem.elastic).volume_ratio(x)
    assert np.min(reference) <= 0 < np.max(reference)
    assert np.allclose(compiled, reference, rtol=1e-12, atol=1e-13)
    assert np.allclose(foam_fem.volume_ratio(q), reference, rtol=1e-12, atol=1e-13)  # the model's, either assembly
