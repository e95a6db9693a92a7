import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")
os.environ.setdefault("MPLBACKEND", "Agg")
# Meshes of bodies given as files are cached here, not in the user's ~/.cache (shared by the
# workers, and by the commands the tests run in subprocesses, which inherit it).
if "LAB_CACHE_DIR" not in os.environ:
    import tempfile

    os.environ["LAB_CACHE_DIR"] = tempfile.mkdtemp(prefix="lab-test-cache-")

import pytest  # noqa: E402

from lab.description import load_robot  # noqa: E402
from lab.fem.model import ArmFEM  # noqa: E402


@pytest.fixture(scope="session")
def three_cable():
    return load_robot("three-cable")


@pytest.fixture(scope="session")
def coarse_fem(three_cable):
    """A coarse three-cable arm: small enough for finite differences over every dof."""
    return ArmFEM(three_cable, n_rings=1, n_axial=6)


@pytest.fixture(scope="session")
def default_fem(three_cable):
    return ArmFEM(three_cable)
