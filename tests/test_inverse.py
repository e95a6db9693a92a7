"""The direct inverse u = g(y) (issue 15): the averaging failure on a redundant toy map,
success on an invertible one, clipping to the command box, files, and its refusals."""

import numpy as np
import pytest

from lab.errors import InputError
from lab.learn import ModelFileError, fit_inverse, init_mlp, inverse_tip_errors, load_inverse
from lab.learn.inverse import InverseModel

FIT = {"epochs": 150}  # Levenberg-Marquardt on 300 samples: well converged, a second


def redundant(u):
    """Two motors, one output: y = u1^2 + u2^2, a circle of commands per y (and its mean, 0, is none)."""
    return np.sum(u * u, axis=1, keepdims=True)


def invertible(u):
    """Two motors, two outputs, one command per tip (det dy/du = 1 - 0.2 u1 + 0.12 u2^2 > 0 on [0, 1]^2)."""
    return np.column_stack([u[:, 0] + 0.3 * u[:, 1] ** 2, u[:, 1] - 0.2 * u[:, 0] * u[:, 1]])


@pytest.fixture(scope="module")
def toys():
    rng = np.random.default_rng(0)
    u_red = rng.uniform(-1.0, 1.0, (300, 2))
    u_inv = rng.uniform(0.0, 1.0, (300, 2))
    return {
        "redundant": (fit_inverse(u_red, redundant(u_red), hidden=(8,), seed=0, **FIT), redundant),
        "invertible": (fit_inverse(u_inv, invertible(u_inv), hidden=(8,), seed=0, **FIT), invertible),
    }


def test_direct_inverse_averages_the_redundant_commands(toys):
    rng = np.random.default_rng(5)
    inv_r, f_r = toys["redundant"]
    inv_i, f_i = toys["invertible"]
    y_r = f_r(rng.uniform(-1.0, 1.0, (100, 2)))
    y_i = f_i(rng.uniform(0.0, 1.0, (100, 2)))
    e_r, e_i = inverse_tip_errors(inv_r, f_r, y_r), inverse_tip_errors(inv_i, f_i, y_i)
    assert e_r.shape == e_i.shape == (100,)
    # the redundant inverse regresses to the mean of the valid commands, u ~ 0, whose tip is y ~ 0:
    # its error is the target itself (mean 2/3), whereas the invertible map's inverse is accurate
    assert np.mean(e_r) > 0.3
    assert np.mean(np.linalg.norm(inv_r.command(y_r), axis=1)) < 0.25  # valid commands: 0.75 on average
    assert np.mean(np.abs(e_r - y_r[:, 0])) < 0.1
    assert np.mean(e_i) < 0.01
    assert np.mean(e_r) > 50 * np.mean(e_i)
    # the robot's shapes, not the network's: 2 motors, 1 or 2 tip coordinates
    assert (inv_r.n_u, inv_r.n_y, inv_i.n_y) == (2, 1, 2)
    assert inv_r.kind == "lab.inverse_mlp" and inv_r.has_jacobian is False


def test_commands_are_clipped_to_the_training_box_and_shapes_follow(toys):
    inv, f = toys["invertible"]
    u = inv.command(np.array([5.0, -5.0]))  # far outside the workspace
    assert u.shape == (2,) and np.all(u >= inv.u_lo) and np.all(u <= inv.u_hi)
    assert np.any(u == inv.u_lo) or np.any(u == inv.u_hi)
    assert np.all(inv.u_lo >= 0.0) and np.all(inv.u_hi <= 1.0)
    assert inv.command(np.zeros((4, 2))).shape == (4, 2)
    with pytest.raises(InputError, match=r"shape \(2,\) or \(N, 2\)"):
        inv.command(np.zeros(3))
    # a forward model's predict or a plain callable judge the same way
    y = f(np.full((3, 2), 0.5))
    net = init_mlp(np.zeros((2, 2)) + [[0, 0], [1, 1]], np.zeros((2, 2)) + [[0, 0], [1, 1]], (3,))
    np.testing.assert_allclose(
        inverse_tip_errors(inv, net, y), inverse_tip_errors(inv, lambda u: net.predict(u), y), rtol=0
    )
    for call in (inv.predict, inv.jacobian, inv.predict_and_jacobian):
        with pytest.raises(InputError, match="no forward map"):
            call(np.zeros(2))


def test_inverse_file_round_trip_and_damage(toys, tmp_path):
    inv, _ = toys["invertible"]
    path = inv.save(tmp_path / "inv.npz")
    back = load_inverse(path)
    assert isinstance(back, InverseModel) and back.metadata["training"]["algorithm"] == "lm"
    y = np.random.default_rng(1).uniform(0, 1, (10, 2))
    np.testing.assert_array_equal(back.command(y), inv.command(y))
    arrays = dict(np.load(path, allow_pickle=False))
    assert {"net.W0", "u_lo", "u_hi", "metadata"} <= set(arrays)
    np.savez(tmp_path / "nobox.npz", **{k: v for k, v in arrays.items() if k != "u_hi"})
    with pytest.raises(ModelFileError, match=r"nobox\.npz.*'u_hi'"):
        load_inverse(tmp_path / "nobox.npz")
    inv.net.save(tmp_path / "net.npz")
    with pytest.raises(ModelFileError, match="is not 'lab.inverse_mlp'"):
        load_inverse(tmp_path / "net.npz")
