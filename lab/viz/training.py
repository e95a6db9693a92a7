"""Chapter 03's training figure: what ``trainlm`` did, epoch by epoch.

:func:`plot_lm_training` draws a :class:`lab.learn.TrainLog` of a Levenberg-Marquardt run
(:func:`lab.learn.train_lm`): on the left the performance (MATLAB's ``mse``, m², log axis)
on the training, validation and test sets with the best epoch marked; on the right the LM
state, the gradient 2 ||J^T e|| / N_e and the damping mu, with the ``min_grad`` stop rule
as a dashed line. Epochs are integers, so the epoch axes carry integer ticks only (a short
run would otherwise get ticks at 2.5, 7.5, ...). The title says why the run stopped, in the
words of :data:`lab.learn.STOP_MESSAGES`.

Drawn here rather than in the notebook so that a test checks what a student sees
(tests/test_figure_fixes.py).
"""

from __future__ import annotations

from lab.viz.style import LIMIT_STYLE, plain_log_ticks

__all__ = ["plot_lm_training"]

SETS = (("perf", "training"), ("vperf", "validation"), ("tperf", "test"))


def plot_lm_training(log, n_train: int, *, figsize=(11, 3.8)):
    """The training figure of a run on ``n_train`` training samples.

    Parameters
    ----------
    log : TrainLog
        A :class:`lab.learn.TrainLog` whose ``history`` has ``epoch``, ``perf``/``vperf``/``tperf``
        in m², ``gradient`` and ``mu``.
    n_train : int
        Training samples of the run.
    figsize : tuple of float, optional
        Figure size (inches).

    Returns
    -------
    tuple
        ``(fig, (ax_perf, ax_lm))``: the matplotlib Figure and its two axes.
    """
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator

    from lab.learn import STOP_MESSAGES

    hist = log.history
    fig, (ax_p, ax_g) = plt.subplots(1, 2, figsize=figsize, layout="constrained")
    for key, label in SETS:
        if len(hist.get(key, ())):
            ax_p.semilogy(hist["epoch"], hist[key], "o-", ms=3, label=label)
    ax_p.axvline(log.best_epoch, color="0.5", ls=":", label=f"best epoch ({log.best_epoch})")
    ax_p.set(xlabel="epoch [1]", ylabel="MSE [m²]", title="performance (MATLAB mse, metres)")
    ax_p.legend()
    ax_g.semilogy(hist["epoch"], hist["gradient"], "o-", ms=3, label=r"gradient $2\|J^\top e\|/N_e$")
    ax_g.semilogy(hist["epoch"], hist["mu"], "s-", ms=3, label=r"$\mu$")
    min_grad = float(log.options.get("min_grad", 0.0))
    if min_grad > 0:
        ax_g.axhline(min_grad, **LIMIT_STYLE, label=f"min_grad = {_short(min_grad)}")
    ax_g.set(xlabel="epoch [1]", ylabel="gradient [m²], μ [1]", title="Levenberg–Marquardt state")
    ax_g.legend()
    for ax in (ax_p, ax_g):
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
        plain_log_ticks(ax, "y")
    fig.suptitle(f"trainlm on {n_train} training samples: {STOP_MESSAGES.get(log.stop_reason, log.stop_reason)}")
    return fig, (ax_p, ax_g)


def _short(x: float) -> str:
    """``1e-06`` as ``1e-6``: Python's exponent without its padding zero."""
    mantissa, _, exponent = f"{x:g}".partition("e")
    return f"{mantissa}e{int(exponent)}" if exponent else mantissa
