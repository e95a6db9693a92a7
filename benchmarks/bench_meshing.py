"""Loading and meshing a CAD-style finger of about 5,000 nodes: the first time and from the cache.

    python benchmarks/bench_meshing.py        # ~10 s; writes benchmarks/bench_meshing.txt

A finger-like gmsh geometry (three tapered phalanges with rounded knuckles on a base
block, in mm) is written to a temporary folder and loaded as a ``"mesh"`` body the way a
description loads it (:func:`lab.description.geometry.read_body_mesh`, then its clamped
base): once with an empty cache (``LAB_CACHE_DIR`` in a fresh folder; gmsh's import and
meshing on one thread included), then five times from the cache (best reported). The
goals are 10 s and 0.5 s. The cached mesh must equal the first one bit for bit. The load
from the cache in a fresh Python process (imports included) is reported beside them.
"""

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
GOAL_FIRST_S, GOAL_CACHED_S = 10.0, 0.5
SIZE_M = 0.0018  # target element size: about 5,000 nodes

FINGER_GEO = """// A finger, mm: base block, three tapered phalanges, spherical knuckles.
SetFactory("OpenCASCADE");
Box(1) = {0, -12, -12, 10, 24, 24};
Cone(2) = {10, 0, 0, 35, 0, 0, 10, 9};
Sphere(3) = {45, 0, 0, 10};
Cone(4) = {45, 0, 0, 27, 0, 0, 9, 8};
Sphere(5) = {72, 0, 0, 9};
Cone(6) = {72, 0, 0, 20, 0, 0, 8, 6.5};
Sphere(7) = {92, 0, 0, 7.5};
BooleanUnion{ Volume{1}; Delete; }{ Volume{2:7}; Delete; }
Physical Volume("finger") = {1};
"""


def main() -> None:
    from lab.description import BodyShape
    from lab.description.geometry import clamped_nodes, read_body_mesh

    with tempfile.TemporaryDirectory() as tmp:
        os.environ["LAB_CACHE_DIR"] = str(Path(tmp) / "cache")
        geo = Path(tmp) / "finger.geo"
        geo.write_text(FINGER_GEO)
        shape = BodyShape("mesh", mesh_file=str(geo), mesh_unit="mm", mesh_size_m=SIZE_M)
        t0 = time.perf_counter()
        first = read_body_mesh(shape)
        clamped = clamped_nodes(first, shape)
        t_first = time.perf_counter() - t0
        t_cached = float("inf")
        for _ in range(5):
            t0 = time.perf_counter()
            again = read_body_mesh(shape)
            clamped_nodes(again, shape)
            t_cached = min(t_cached, time.perf_counter() - t0)
        assert np.array_equal(first.X_m, again.X_m) and np.array_equal(first.tets, again.tets)
        code = (
            "import time; t0 = time.perf_counter(); from lab.description import BodyShape; "
            "from lab.description.geometry import read_body_mesh; "
            f"read_body_mesh(BodyShape('mesh', mesh_file={str(geo)!r}, mesh_unit='mm', mesh_size_m={SIZE_M})); "
            "print(time.perf_counter() - t0)"
        )
        env = {**os.environ, "PYTHONPATH": str(ROOT)}
        argv = [sys.executable, "-c", code]
        t_process = min(
            float(subprocess.run(argv, env=env, check=True, capture_output=True, text=True).stdout) for _ in range(3)
        )
    n, m = len(first.X_m), len(first.tets)
    ok_first, ok_cached = t_first <= GOAL_FIRST_S, t_cached <= GOAL_CACHED_S
    lines = [
        f"Loading a gmsh finger geometry (mm, [mesh] size_m = {SIZE_M} m): {n:,} nodes, {m:,} tets, "
        f"{int(clamped.sum())} clamped (one gmsh thread)",
        f"  first time (empty cache): {t_first:6.2f} s  (goal {GOAL_FIRST_S:g} s: {'ok' if ok_first else 'OVER'})",
        f"  from the cache, best of 5: {t_cached:6.3f} s  (goal {GOAL_CACHED_S:g} s: {'ok' if ok_cached else 'OVER'})",
        f"  from the cache in a fresh process, importing lab.description included, best of 3: {t_process:6.3f} s",
    ]
    text = "\n".join(lines) + "\n"
    print(text, end="")
    (ROOT / "benchmarks" / "bench_meshing.txt").write_text(text)
    if not (ok_first and ok_cached):
        sys.exit(1)


if __name__ == "__main__":
    main()
