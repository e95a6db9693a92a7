"""What an import cannot get silently wrong: units, IDs, numbers, and the output's lock file."""

import os

import numpy as np
import pytest

from lab.cli import main
from lab.data.csv_table import NAN, NON_NUMERIC, OK, read_table
from lab.data.importing import _id_key
from lab.data.plausibility import PLAUSIBLE, largest, unit_hint
from lab.errors import InputError
from lab.files import exclusive_lock

ROWS = "a,b,x,y,z\n0.1,0.2,1,2,3\n0.3,0.4,1.1,2.1,3.1\n"


def test_summary_names_the_units_read_and_the_default(tmp_path, capsys):
    (tmp_path / "f.csv").write_text(ROWS)
    argv = ["import-data", str(tmp_path / "f.csv"), "--u", "a,b", "--y", "x,y,z", "--y-unit", "mm"]
    assert main([*argv, "--out", str(tmp_path / "o.csv")]) == 0
    out = capsys.readouterr().out
    assert "units: inputs rad (the default of --u-unit; give --u-unit if" in out and "positions mm, written in m" in out
    assert main([*argv, "--u-unit", "N", "--out", str(tmp_path / "p.csv")]) == 0
    assert "units: inputs N; positions mm" in capsys.readouterr().out


def test_unit_hint_names_the_unit_every_value_fits():
    low, high = PLAUSIBLE["m"]
    assert unit_hint(np.array([10.0, 182.0, np.nan]), "m", "m", low, high) == "mm"
    assert unit_hint(np.array([1e5]), "m", "m", low, high) is None  # no unit makes 100 km plausible
    assert unit_hint(np.array([900.0]), "cm", "m", low, high) == "mm"
    assert unit_hint(np.array([90.0]), "rad", "rad", 0.0, 3.0) == "deg"  # a robot's range, for a commands file
    assert largest(np.array([3.0, -182.0, 12.0])) == -182.0


def test_ids_are_compared_exactly():
    assert _id_key("7") == _id_key("7.0") == _id_key(" 7") == _id_key("7e0") == _id_key("+7")
    assert _id_key("0") == _id_key("-0.0")
    assert _id_key("90071992547409930") != _id_key("90071992547409931")  # equal as floats
    assert len({_id_key(f"17328600000000000{k:02d}") for k in range(50)}) == 50
    assert _id_key("1_000") == "1_000" and _id_key("abc") == "abc"  # text: as it is


def test_numbers_are_ascii_without_underscores(tmp_path):
    f = tmp_path / "f.csv"
    f.write_text("a,b\n1_000,2\n\u0661,\uff12\n1e3, 4 \nnan,\n")
    values, kind = read_table(f).numbers(("a", "b"), "test")
    np.testing.assert_array_equal(kind, [[NON_NUMERIC, OK], [NON_NUMERIC, NON_NUMERIC], [OK, OK], [NAN, NAN]])
    np.testing.assert_array_equal(values[2], [1000.0, 4.0])
    good = tmp_path / "g.csv"
    good.write_text("a\n" + "".join(f"{float(v)!r}\n" for v in np.linspace(-1, 1, 101)))  # the whole-column path
    np.testing.assert_array_equal(read_table(good).numbers(("a",), "t")[0][:, 0], np.linspace(-1, 1, 101))


def test_a_header_naming_a_column_twice_is_refused_even_unused(tmp_path):
    f = tmp_path / "f.csv"
    f.write_text("a,b,note,note\n1,2,x,y\n")
    with pytest.raises(InputError, match=r"f.csv: line 1: the header names the column\(s\) 'note' more than once"):
        read_table(f)


def test_only_regular_files_are_read(tmp_path):
    os.mkfifo(tmp_path / "pipe.csv")  # opening it would wait for a writer for ever
    for path in (tmp_path / "pipe.csv", "/dev/zero"):
        with pytest.raises(InputError, match="is not a regular file"):
            read_table(path)


def test_exclusive_lock_never_removes_a_file_it_did_not_create(tmp_path):
    lock = tmp_path / "o.csv.lock"
    with exclusive_lock(lock, "busy"):
        assert lock.exists()
    assert not lock.exists()  # its own: removed
    lock.write_text("")  # a killed run's lock: taken, and left as it was
    with exclusive_lock(lock, "busy"):
        pass
    assert lock.read_bytes() == b""
    lock.write_text("a user's data\n")
    with pytest.raises(InputError, match="exists and is not a lock file"), exclusive_lock(lock, "busy"):
        pass
    assert lock.read_text() == "a user's data\n"
    lock.unlink()
    lock.mkdir()
    with pytest.raises(InputError, match="not a plain file"), exclusive_lock(lock, "busy"):
        pass
    assert lock.is_dir()
