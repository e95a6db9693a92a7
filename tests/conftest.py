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

        def _assign_work_unit(self, node):
            if not getattr(self, "_longest_first", False):  # once, before the first unit goes out
                self._longest_first = True
                quick = _quick_times()  # read once
                order = sorted(self.workqueue, key=lambda scope: -_expected_s(scope, len(self.workqueue[scope]), quick))
                for scope in order:
                    self.workqueue.move_to_end(scope)
            super()._assign_work_unit(node)

    return ChapterScheduling(config, log)


#: Scopes (test files) that take far longer than their number of tests says: the sum of their
#: tests' wall times, s, in a suite run on an idle 2-core machine (3 workers; the site's Sphinx
#: build, real-time emulators, subprocesses, browsers), for those of 10 s or more. Handed out
#: early, they no longer end the suite with one worker busy and the other core idle.
_LONG_SCOPES = {
    "tests/test_docs_site.py": 107.0,
    "tests/test_watchdog.py": 32.0,
    "tests/test_dynamixel.py": 24.0,
    "tests/test_predictive.py": 23.0,
    "tests/test_user_robot.py": 22.0,
    "tests/test_chambered_body.py": 22.0,
    "tests/test_reproduce_partial.py": 21.0,
    "tests/test_sampling.py": 19.0,
    "tests/test_jupyterlab.py": 18.0,
    "tests/test_live_meshcat.py": 18.0,
    "tests/test_closed_loop.py": 14.0,
    "tests/test_dynamics.py": 14.0,
    "tests/test_calibrate.py": 14.0,
    "tests/test_workers_killed.py": 13.0,
    "tests/test_course_edition.py": 12.0,
    "tests/test_lhs.py": 12.0,
    "tests/test_viz.py": 12.0,
    "tests/test_notebooks.py": 12.0,
    "tests/test_examples_chambers_cli.py": 12.0,
    "tests/test_reproduce_pool.py": 12.0,
    "tests/test_capture.py": 11.0,
    "tests/test_natnet.py": 11.0,
    "tests/test_animation.py": 11.0,
    "tests/test_timeouts.py": 10.0,
}


def _expected_s(scope: str, n_tests: int, quick: dict) -> float:
    """A rough duration of a scheduling scope, for handing out the longest first: a chapter's
    quick run (its three checks share it) from ``quick`` (figures/chapter_times.csv), a known long file,
    else 0.2 s per test. xdist's own order (most tests first) sent the chapters last, so the
    suite ended with one worker running a chapter while the other waited."""
    if scope.startswith("chapter "):
        return 2.0 * quick.get(scope.removeprefix("chapter "), 30.0)
    return _LONG_SCOPES.get(scope, 0.2 * n_tests)


def _quick_times() -> dict:
    import csv
    from pathlib import Path

    path = Path(__file__).resolve().parent.parent / "figures" / "chapter_times.csv"
    try:
        with path.open(newline="") as fh:
            return {r["chapter"]: float(r["quick_s"] or 30.0) for r in csv.DictReader(fh)}
    except (OSError, KeyError, ValueError):
        return {}
