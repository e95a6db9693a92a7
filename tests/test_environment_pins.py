"""environment.txt installs on every platform the course names: the Intel MKL family (which
ships wheels only for x86-64 Linux and Windows) carries a platform marker, so pip skips it on
arm64 and macOS and the FEM falls back to SciPy; everything else is pinned exactly."""

from __future__ import annotations

from pathlib import Path

import pytest
from packaging.markers import default_environment
from packaging.requirements import Requirement

ROOT = Path(__file__).resolve().parent.parent
MKL_FAMILY = {"mkl", "intel-openmp", "intel-cmplr-lib-ur", "tbb", "tcmlib", "umf", "pypardiso"}
PLATFORMS = {
    "linux-x86_64": ({"platform_machine": "x86_64", "sys_platform": "linux"}, True),
    "windows-amd64": ({"platform_machine": "AMD64", "sys_platform": "win32"}, True),
    "linux-aarch64": ({"platform_machine": "aarch64", "sys_platform": "linux"}, False),
    "macos-arm64": ({"platform_machine": "arm64", "sys_platform": "darwin"}, False),
    "macos-x86_64": ({"platform_machine": "x86_64", "sys_platform": "darwin"}, False),
}


def requirements() -> list[Requirement]:
    lines = (ROOT / "environment.txt").read_text().splitlines()
    return [Requirement(line) for line in (ln.split(" #")[0].strip() for ln in lines) if line and line[0] != "#"]


def test_every_pin_is_exact():
    for req in requirements():
        assert len(req.specifier) == 1 and next(iter(req.specifier)).operator == "==", str(req)


@pytest.mark.parametrize("platform", PLATFORMS)
def test_mkl_family_installs_only_where_it_has_wheels(platform):
    overrides, has_mkl = PLATFORMS[platform]
    env = {**default_environment(), **overrides}
    reqs = requirements()
    names = {r.name.lower() for r in reqs}
    assert MKL_FAMILY <= names
    for req in reqs:
        applies = req.marker is None or req.marker.evaluate(env)
        if req.name.lower() in MKL_FAMILY:
            assert applies == has_mkl, (platform, str(req))
        else:
            assert applies, (platform, str(req))  # the rest (torch, numpy, scipy, ...) everywhere
