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


@pytest.fixture(scope="session")
def chapter_runs(tmp_path_factory):
    """Each chapter's one quick run, shared by its checks (``tests/chapter_run.py``)."""
    from chapter_run import ChapterRuns

    return ChapterRuns(tmp_path_factory.mktemp("chapters"))


@pytest.hookimpl(optionalhook=True, tryfirst=True)
def pytest_xdist_make_scheduler(config, log):
    """xdist's ``--dist loadfile`` (scripts/test) or ``load`` (``-n`` alone), except that a
    chapter's checks that share its run (``chapter_run.SHARED_CHECKS``) go to one worker
    together, so that no two workers run the same chapter. Other modes are xdist's own."""
    dist = config.getvalue("dist")
    if dist not in ("load", "loadfile"):
        return None
    from chapter_run import chapter_of
    from xdist.scheduler import LoadFileScheduling, LoadScopeScheduling

    class ChapterScheduling(LoadFileScheduling if dist == "loadfile" else LoadScopeScheduling):
        def _split_scope(self, nodeid):
            if chapter := chapter_of(nodeid):
                return f"chapter {chapter}"
            return super()._split_scope(nodeid) if dist == "loadfile" else nodeid

    return ChapterScheduling(config, log)
