"""Shared timing helper of the benchmark scripts (imported from the scripts' folder)."""

import time


def best_of(fn, n=7):
    """Smallest wall time in seconds of ``n`` calls of ``fn()`` (least disturbed by other load)."""
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)
