"""Sim-to-real transfer from data (issue 14): time to build each model against N real
samples, and the model error each reaches, on the emulated as-built three-cable robot.

    python benchmarks/bench_transfer.py          # ~2 minutes on 2 cores

For N in {5, 10, 30, 100, 308}: the wall time of ``real-only`` (LM on the N samples),
``finetune-last`` and ``finetune`` (LM with the prior, its weight cross-validated) and
``residual`` (GP fit), and their mean error on the 308 captured samples they were not
trained on (the first N of a maximin order are used for training). The ratio column is
each method's time over ``finetune-last``'s at the same N, measured in the same run.
"""

import time

import numpy as np

from lab.data import read_dataset
from lab.data.designs import greedy_maximin
from lab.learn import load_model
from lab.transfer import transfer_model

u_all, y_all, _ = read_dataset("data/real_three_cable.csv")  # the shipped emulated as-built capture
sim = load_model("data/model_sim_three_cable.npz")
x = u_all / u_all.max()
order = greedy_maximin(x, int(np.argmax(np.linalg.norm(x - x.mean(0), axis=1))), len(u_all))
methods = ("finetune-last", "real-only", "finetune", "residual")
print(f"{'N':>4} {'method':>14} {'fit [s]':>8} {'x finetune-last':>15} {'error on the rest [mm]':>23}")
for n in (5, 10, 30, 100, 308):
    train, rest = order[:n], order[n:] if n < len(order) else order
    times = {}
    for method in methods:
        t0 = time.perf_counter()
        model = transfer_model(method, u_all[train], y_all[train], sim)
        times[method] = time.perf_counter() - t0
        err = 1e3 * np.mean(np.linalg.norm(model.predict(u_all[rest]) - y_all[rest], axis=1))
        print(f"{n:4d} {method:>14} {times[method]:8.2f} {times[method] / times['finetune-last']:15.1f} {err:23.3f}")
print("(N = 308: the error is on the training samples themselves)")
