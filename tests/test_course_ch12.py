"""Chapter 12's graders (lab.course.ch12) pass a right answer and catch the wrong ones a
student is likely to write.

Each correct implementation below is written independently of the grader's reference (the
volume about the surface's centroid by scalar triple products, not determinants about the
origin; the gradient by the cross products of the edges, not by differences), and the
gradient is also checked against lab's own ``PressureChamberActuator.volume_gradients`` on
the pneumatic arm's mesh.
"""

import numpy as np
from helpers import assert_reruns

from lab.course.ch12 import check_enclosed_volume, check_volume_gradient


def _passed(result) -> bool:
    return result.status == "passed"


def _volume(x, t, sign=-1.0, about_centroid=True):
    x = np.asarray(x, float)
    c = x[np.unique(t)].mean(axis=0) if about_centroid else np.zeros(3)
    a, b, d = x[t[:, 0]] - c, x[t[:, 1]] - c, x[t[:, 2]] - c
    return sign * float(np.sum(a * np.cross(b, d))) / 6.0


def _gradient(x, t, scale=1.0, accumulate=True):
    x = np.asarray(x, float)
    g = np.zeros_like(x)
    for k in range(3):
        b, c = x[t[:, (k + 1) % 3]], x[t[:, (k + 2) % 3]]
        if accumulate:
            np.add.at(g, t[:, k], -scale * np.cross(b, c) / 6.0)
        else:  # g[t] += ... keeps one triangle per node, not the sum
            g[t[:, k]] += -scale * np.cross(b, c) / 6.0
    return g


def test_enclosed_volume_grader():
    assert _passed(check_enclosed_volume(_volume, show=False))
    assert _passed(check_enclosed_volume(lambda x, t: _volume(x, t, about_centroid=False), show=False))
    for wrong in (
        lambda x, t: abs(_volume(x, t)),  # no sign: wrong for a surface wound outwards
        lambda x, t: _volume(x, t, sign=+1.0),  # the winding read the other way round
        lambda x, t: 6.0 * _volume(x, t),  # parallelepipeds, not tetrahedra
    ):
        assert not _passed(check_enclosed_volume(wrong, show=False))
    assert_reruns(check_enclosed_volume(wrong, show=False), lambda k: check_enclosed_volume(wrong, case=k, show=False))


def test_volume_gradient_grader():
    assert _passed(check_volume_gradient(_gradient, show=False))
    for wrong in (
        lambda x, t: _gradient(x, t, scale=-1.0),  # the outward winding's sign
        lambda x, t: _gradient(x, t, scale=3.0),  # 1/2 for 1/6
        lambda x, t: _gradient(x, t, accumulate=False),  # buffered fancy-index add
    ):
        assert not _passed(check_volume_gradient(wrong, show=False))
    assert_reruns(check_volume_gradient(wrong, show=False), lambda k: check_volume_gradient(wrong, case=k, show=False))


def test_gradient_matches_the_chamber_actuator():
    from lab.description import load_robot
    from lab.fem import ArmFEM

    fem = ArmFEM(load_robot("pneumatic-arm"))
    chambers = fem.actuators[0]
    x = fem.X_W + np.random.default_rng(0).normal(0.0, 1e-4, fem.X_W.shape)
    lab_dV = chambers.volume_gradients(x)  # (n_free, 3 chambers)
    for c, tri in enumerate(chambers.surfaces):
        assert np.allclose(_gradient(x, tri).ravel()[fem.free_dofs], lab_dV[:, c], rtol=1e-10, atol=1e-16)
        assert abs(_volume(x, tri) - chambers.volumes(x)[c]) < 1e-12 * chambers.V0_m3[c] * 1e3
