"""Output checks made before any work: they create nothing, and refuse what cannot be written."""

from __future__ import annotations

import os

import pytest

from lab.cli import main
from lab.cli.paths import check_writable, output_lock
from lab.errors import InputError


def test_check_writable_creates_no_directory(tmp_path):
    out = tmp_path / "new" / "deeper" / "model.npz"
    check_writable(out)
    assert not (tmp_path / "new").exists()


def test_check_writable_refuses_a_file_as_parent_and_a_directory(tmp_path):
    (tmp_path / "f").write_text("x")
    with pytest.raises(InputError, match="is a file, not a directory"):
        check_writable(tmp_path / "f" / "sub" / "out.csv")
    with pytest.raises(InputError, match="is a directory"):
        check_writable(tmp_path)


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write anywhere")
def test_check_writable_refuses_a_read_only_ancestor(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        with pytest.raises(InputError, match="cannot write"):
            check_writable(ro / "new" / "out.csv", "--out")
    finally:
        ro.chmod(0o700)


def test_a_refused_run_leaves_no_empty_directory(tmp_path, capsys):
    out = tmp_path / "results" / "model.npz"
    assert main(["train", str(tmp_path / "missing.csv"), "--out", str(out)]) == 2
    assert not (tmp_path / "results").exists()
    assert "missing.csv" in capsys.readouterr().err


def test_the_output_lock_creates_the_parent_when_the_run_starts(tmp_path):
    out = tmp_path / "new" / "table.csv"
    with output_lock(out):
        assert (tmp_path / "new").is_dir()
    assert not (tmp_path / "new" / "table.csv.lock").exists()
