"""Speed of the learned model: LM training, forward + analytic Jacobian, analytic vs autograd.

    python benchmarks/bench_model.py      # ~1 minute, one thread (OMP/MKL_NUM_THREADS=1)

Targets of issue 3: LM training of 3-20-20-3 on the 308 samples < 10 s; forward +
analytic Jacobian for a batch of 10,000 inputs < 10 ms; the analytic Jacobian at least as
fast as torch autograd on the same batch (ratio reported). Times are the best of several
repetitions; torch runs on one thread like NumPy's BLAS here.
"""

import os
import time
from pathlib import Path

import numpy as np
from timing import best_of

from lab.data.dataset import read_dataset
from lab.learn.lm import LMOptions
from lab.learn.train import train

DATA = Path(__file__).resolve().parent.parent / "data" / "sim_three_cable.csv"


print(f"threads per process: OMP={os.environ.get('OMP_NUM_THREADS')} MKL={os.environ.get('MKL_NUM_THREADS')}")
u, y, _ = read_dataset(DATA)
print(f"\nLM training (trainlm semantics) of 3-20-20-3 on {DATA.name} ({len(u)} samples):")
for label, kwargs in (
    ("80/10/10 split, paper's stopping rules", dict(ratios=(0.8, 0.1, 0.1))),
    ("90/10 split (the 10-split study), paper's rules", dict(ratios=(0.9, 0.0, 0.1))),
    ("all 308 samples, full 1000 epochs (min_grad = 0)", dict(ratios=(1.0, 0.0, 0.0), options=LMOptions(min_grad=0.0))),
):
    walls, epochs = [], []
    for seed in range(3):
        t0 = time.perf_counter()
        res = train(u, y, (20, 20), seed=seed, **kwargs)
        walls.append(time.perf_counter() - t0)
        epochs.append(res.log.epochs)
        if kwargs.get("options"):
            break
    print(
        f"  {label}: {np.mean(walls):.2f} s per run (max {max(walls):.2f} s, target < 10 s), "
        f"{np.mean(epochs):.0f} epochs, {1e3 * sum(walls) / sum(epochs):.1f} ms per epoch"
    )

rng = np.random.default_rng(0)
model = res.model
U = rng.uniform(0.0, 3.0, (10_000, 3))
t_fwd = best_of(lambda: model.predict(U), 20)
t_jac = best_of(lambda: model.predict_and_jacobian(U), 20)
t_one = best_of(lambda: model.predict_and_jacobian(U[0]), 2000)
print(f"\nbatch of {len(U)} inputs, 3-20-20-3:")
print(f"  forward only                  {1e3 * t_fwd:7.2f} ms")
print(f"  forward + analytic Jacobian   {1e3 * t_jac:7.2f} ms  (target < 10 ms)")
print(f"  one input (n_u,): forward + Jacobian {1e6 * t_one:.1f} us")

import torch  # noqa: E402  (after the NumPy timings: importing torch loads its own BLAS)

torch.set_num_threads(1)
T = lambda a: torch.tensor(a, dtype=torch.float64)  # noqa: E731
Ws, bs = [T(w) for w in model.weights], [T(b) for b in model.biases]
u_min, u_gain, y_min, y_gain = T(model.u_min), T(model.u_gain), T(model.y_min), T(model.y_gain)


def f(u):
    a = (u - u_min) * u_gain - 1.0
    for W, b in zip(Ws[:-1], bs[:-1]):
        a = torch.tanh(a @ W.T + b)
    return (a @ Ws[-1].T + bs[-1] + 1.0) / y_gain + y_min


U_t = T(U)
vmapped = torch.func.vmap(torch.func.jacrev(f))


def rows_by_backward():  # samples are independent: d(sum_i y_ik)/du_i = row k of J_i
    u = U_t.clone().requires_grad_(True)
    out = f(u)
    return torch.stack([torch.autograd.grad(out[:, k].sum(), u, retain_graph=k < 2)[0] for k in range(3)], 1)


J_np = model.jacobian(U)
for name, fn in (
    ("torch.func.vmap(jacrev)", lambda: vmapped(U_t)),
    ("autograd, one backward per output", rows_by_backward),
):
    err = np.abs(fn().detach().numpy() - J_np).max() / np.abs(J_np).max()
    t = best_of(fn, 20)
    print(f"  {name:<34} {1e3 * t:7.2f} ms   analytic is {t / t_jac:.1f}x faster (max rel. difference {err:.1e})")
