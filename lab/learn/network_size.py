"""How much memory training a network needs, checked before any weight is allocated.

Levenberg-Marquardt (and Bayesian regularisation) solves an ``m x m`` system per epoch,
``m`` the number of parameters -- or of residuals, when there are fewer and the Jacobian
fits in its memory budget (:func:`lab.learn.lm._jacobian_products`) -- so a network of
100,000 hidden neurons would ask for terabytes. :func:`check_network_size` estimates the
bytes a training run needs and refuses one that cannot fit in the memory available now,
like :func:`lab.fem.bodies.mesh.check_mesh_size` for meshes; :func:`lab.learn.train.train`
calls it before initialising the weights.
"""

from __future__ import annotations

from lab.errors import FieldError
from lab.fem.bodies.mesh import available_memory_bytes
from lab.files import format_bytes

__all__ = ["n_parameters", "training_bytes", "check_network_size"]

#: How an error names the hidden widths (the command line writes its ``--hidden``).
HIDDEN = "TrainSpec.hidden"

#: LM's Jacobian budget, MB (:class:`lab.learn.lm.LMOptions`' ``max_jacobian_mb``).
JACOBIAN_BUDGET_MB = 256.0


def n_parameters(layer_sizes) -> int:
    """Weights and biases of a network with ``layer_sizes`` (n_u, hidden..., n_y)."""
    sizes = [int(s) for s in layer_sizes]
    return sum((a + 1) * b for a, b in zip(sizes[:-1], sizes[1:]))


def training_bytes(layer_sizes, n_train: int, algorithm: str = "lm", max_jacobian_mb: float = JACOBIAN_BUDGET_MB):
    """Estimated peak memory (bytes) of training ``layer_sizes`` on ``n_train`` samples by
    ``algorithm`` ("lm", "br", "lm-subsample", "adam", "lbfgs"): parameter vectors,
    activations and, for the LMs and BR, the Jacobian and the damped system with its
    factorisation (an upper bound for "lm-subsample", whose Jacobian covers fewer rows)."""
    sizes = [int(s) for s in layer_sizes]
    n_p, n_y, n = n_parameters(sizes), sizes[-1], max(int(n_train), 1)
    vectors = 32 * 8 * n_p  # weights, best weights, steps, gradients, optimiser history
    activations = 3 * 8 * n * sum(sizes)  # forward and backward passes
    if algorithm not in ("lm", "br", "lm-subsample", "auto"):  # no Jacobian, no system
        return vectors + activations
    n_e, budget = n * n_y, max_jacobian_mb * 2**20
    if n_p > n_e and 8 * n_e * n_p <= budget:  # the kernel form: an (N n_y)^2 system
        m, jacobian = n_e, 8 * n_e * n_p
    else:  # the primal form: n_params^2, the Jacobian built in chunks
        m, jacobian = n_p, max(min(8 * n_e * n_p, budget), 8 * n_y * n_p)
    systems = (3 if algorithm == "br" else 2) * 8 * m * m  # J^T J, its damped copy (BR: eigenvectors)
    return vectors + activations + 2 * jacobian + systems


def check_network_size(
    layer_sizes, n_train: int, algorithm: str = "lm", copies: int = 1, available_bytes: int | None = None
) -> int:
    """Refuse (a FieldError naming ``TrainSpec.hidden``) training ``layer_sizes`` (n_u, hidden..., n_y)
    on ``n_train`` samples by ``algorithm`` when ``copies`` such runs at once (parallel
    workers) would not fit in the memory available now; returns the estimate in bytes.

    Parameters
    ----------
    layer_sizes : sequence of int
        (n_u, hidden..., n_y).
    n_train : int
        Training samples.
    algorithm : str
        ``"lm"``, ``"br"``, ``"adam"`` or ``"lbfgs"``.
    copies : int
        Runs at once.
    available_bytes : int, optional
        Memory available, bytes (default: measured now).

    Returns
    -------
    int
        The estimated peak memory of the ``copies`` runs, bytes.
    """
    sizes = tuple(int(s) for s in layer_sizes)
    need = copies * training_bytes(sizes, n_train, algorithm)
    have = available_memory_bytes() if available_bytes is None else available_bytes
    if need > have:
        times = f" ({copies} at once)" if copies > 1 else ""
        raise FieldError(
            f"{HIDDEN} {' '.join(map(str, sizes[1:-1]))}: a {'-'.join(map(str, sizes))} network "
            f"({n_parameters(sizes):,} parameters) trained by {algorithm} on {n_train} samples{times} would need "
            f"about {format_bytes(need)} of memory; this machine has {format_bytes(have)} available. "
            "Use fewer or narrower hidden layers.",
            HIDDEN,
        )
    return need
