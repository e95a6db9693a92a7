"""``python -m lab import-data``: external measurements become lab datasets, rows and provenance intact.

The library (:mod:`lab.data.importing`) on small hand-made files: row-by-row and ID joins
(reordered and unmatched IDs), ``--group`` sequences, mm/cm -> m, the phantom-ID rule,
dropped-row counts and the recorded SHA-256; any number of position columns. Then the
shipped ASL Trunk import, re-run from the command its sidecar records: the same bytes, the
counts, the sequences, the input ranges and the first tip row against the raw files; and the
command end to end in a fresh process. Bad input is the fault sweep's (tests/sweep_import.py).
"""

import hashlib
import json
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from helpers import subprocess_env

from lab.data import ImportSpec, import_dataset, read_dataset, read_measurements, sequence_ids
from lab.errors import InputError

ROOT = Path(__file__).resolve().parent.parent
RAW = ROOT / "data" / "third_party" / "asl-trunk" / "raw"


def write(d: Path, name: str, text: str) -> Path:
    p = d / name
    p.write_text(text)
    return p


def spec(**kw) -> ImportSpec:
    return ImportSpec(**{"u": ("a", "b"), "y": ("x", "y", "z"), "y_unit": "mm", **kw})


def test_row_join_two_pairs_each_a_sequence(tmp_path):
    i1 = write(tmp_path, "i1.csv", "\ufeffa,b\n1,2\n\n3,4\n")  # a byte-order mark, a blank line
    o1 = write(tmp_path, "o1.csv", "x,y,z\n10,20,30\n11,21,31")  # no final newline
    i2 = write(tmp_path, "i2.csv", "b,a\n6,5\n")  # columns in another order
    o2 = write(tmp_path, "o2.csv", "z,y,x,extra\n32,22,12,q\n")
    m = read_measurements(spec(), [i1, i2], [o1, o2])
    np.testing.assert_array_equal(m.u, [[1, 2], [3, 4], [5, 6]])
    np.testing.assert_allclose(m.y_m * 1e3, [[10, 20, 30], [11, 21, 31], [12, 22, 32]])
    assert m.sequence_starts == [0, 2]
    assert [(g["start"], g["stop"], g["join"]) for g in m.row_groups] == [(0, 2, "row"), (2, 3, "row")]
    src = m.row_groups[1]["sources"]
    assert src[0]["path"] == str(i2) and src[0]["columns"] == ["a", "b"] and src[1]["columns"] == ["x", "y", "z"]
    assert src[1]["sha256"] == hashlib.sha256(o2.read_bytes()).hexdigest()


def test_id_join_keeps_input_order_and_counts_unmatched(tmp_path):
    i = write(tmp_path, "i.csv", "ID,a,b\n0,1,2\n1,3,4\n2,5,6\n3,7,8\n")
    o = write(tmp_path, "o.csv", "x,y,z,ID\n13,23,33,3.0\n10,20,30,0\n19,29,39,9\n11,21,31, 1\n")
    m = read_measurements(spec(id="ID"), [i], [o])
    np.testing.assert_array_equal(m.u[:, 0], [1, 3, 7])  # input 2 has no observation
    np.testing.assert_allclose(m.y_m[:, 0] * 1e3, [10, 11, 13])  # matched on the ID's value, not its text
    assert m.row_groups[0]["dropped"] == {"nan": 0, "non_numeric": 0, "unmatched_id": 2}  # input 2, obs 9
    assert m.row_groups[0]["join"] == "id" and m.row_groups[0]["sources"][0]["columns"][-1] == "ID"


def test_group_column_starts_sequences_within_and_across_files(tmp_path):
    f1 = write(tmp_path, "f1.csv", "a,b,x,y,z,run\n" + "".join(f"{k},0,0,0,0,{r}\n" for k, r in enumerate("AABBA")))
    f2 = write(tmp_path, "f2.csv", "a,b,x,y,z,run\n9,0,0,0,0,A\n9,0,0,0,0,A\n")  # same value: still a new file
    m = read_measurements(spec(group="run"), [f1, f2])
    assert m.sequence_starts == [0, 2, 4, 5]
    np.testing.assert_array_equal(sequence_ids(m.__dict__, len(m.u)), [0, 0, 1, 1, 2, 3, 3])


@pytest.mark.parametrize("unit, factor", [("m", 1.0), ("cm", 0.01), ("mm", 0.001)])
def test_positions_are_converted_to_metres(tmp_path, unit, factor):
    f = write(tmp_path, "f.csv", "a,b,x,y,z\n0.5,-1,1,-2.5,0.03\n")
    m = read_measurements(spec(y_unit=unit), [f])
    np.testing.assert_allclose(m.y_m, [[1 * factor, -2.5 * factor, 0.03 * factor]], rtol=1e-15)
    np.testing.assert_array_equal(m.u, [[0.5, -1]])  # inputs are never scaled


def test_phantom_id_rule(tmp_path):
    i = write(tmp_path, "i.csv", "ID,a,b\n5,1,2\n6,3,4\n")
    o = write(tmp_path, "o.csv", "ID,x,y,z\n10,20,30\n11,21,31\n")  # the header's ID has no values
    for kw in ({"id": "ID"}, {}):
        m = read_measurements(spec(**kw), [i], [o])
        np.testing.assert_allclose(m.y_m[:, 0] * 1e3, [10, 11])
        assert m.row_groups[0]["join"] == "row" and "phantom-ID rule" in " ".join(m.notes)
    alone = write(tmp_path, "alone.csv", "index,a,b,x,y,z\n1,2,3,4,5\n")
    np.testing.assert_array_equal(read_measurements(spec(), [alone]).u, [[1, 2]])
    other = write(tmp_path, "other.csv", "key,x,y,z\n10,20,30\n")  # not an ID name: no rule
    with pytest.raises(InputError, match=r"other.csv: line 2 has 3 fields, the header has 4"):
        read_measurements(spec(), [write(tmp_path, "i1.csv", "a,b\n1,2\n")], [other])


def test_bad_values_are_an_error_or_dropped_and_counted(tmp_path):
    f = write(tmp_path, "f.csv", "a,b,x,y,z\n1,2,3,4,5\n1,two,3,4,5\n1,2,nan,4,5\n1,2,,4,5\n1,-inf,3,4,5\n6,7,8,9,1\n")
    with pytest.raises(InputError, match=r"f.csv: line 3, column 'b' \(ImportSpec.u\): 'two' is not a number"):
        read_measurements(spec(), [f])
    m = read_measurements(spec(drop_bad_rows=True), [f])
    np.testing.assert_array_equal(m.u, [[1, 2], [6, 7]])
    assert m.row_groups[0]["dropped"] == {"nan": 3, "non_numeric": 1, "unmatched_id": 0}
    assert m.sequence_starts == [0]


def test_any_number_of_position_columns_but_a_dataset_needs_three(tmp_path):
    obs = RAW / "observations_steady_state_beta_seed0.csv"
    nine = tuple(f"{c}{k}" for k in (1, 2, 3) for c in "xyz")
    s = ImportSpec(u=tuple(f"u{k}" for k in range(1, 7)), y=nine, id="ID")
    m = read_measurements(s, [RAW / "control_inputs_beta_seed0.csv"], [obs])
    assert m.u.shape == (150, 6) and m.y_m.shape == (150, 9)
    np.testing.assert_array_equal(m.y_m[0], np.loadtxt(obs, delimiter=",", skiprows=1)[0, 1:])
    with pytest.raises(InputError, match="exactly 3"):
        import_dataset(s, [RAW / "control_inputs_beta_seed0.csv"], tmp_path / "o.csv", observations=[obs])
    assert not (tmp_path / "o.csv").exists()


def test_file_size_limit(tmp_path, monkeypatch):
    import lab.data.csv_table as csv_table

    f = write(tmp_path, "f.csv", "a,b,x,y,z\n1,2,3,4,5\n")
    monkeypatch.setattr(csv_table, "MAX_IMPORT_BYTES", 10)
    with pytest.raises(InputError, match="f.csv: .* larger than an import reads"):
        read_measurements(spec(), [f])


def test_spec_refuses_a_column_given_twice():
    with pytest.raises(InputError, match="ImportSpec.u names the column 'a' twice"):
        spec(u=("a", "a"))
    with pytest.raises(InputError, match="'x' is given in both ImportSpec.u and ImportSpec.y"):
        spec(u=("a", "x"))
    with pytest.raises(InputError, match="ImportSpec.id"):
        spec(id="a")


def shipped_command(name: str, out: Path) -> list[str]:
    _, _, meta = read_dataset(ROOT / "data" / f"{name}.csv")
    words = shlex.split(meta["command"])
    assert words[:4] == ["python", "-m", "lab", "import-data"]
    words[words.index("--out") + 1] = str(out)
    return words[3:]


def test_shipped_asl_import_is_reproduced(tmp_path, monkeypatch, capsys):
    from lab.cli import main

    monkeypatch.chdir(ROOT)  # the recorded command names the raw files from the repository root
    expected = {"asl_trunk_oct2024": (3489, 28, 0.647), "asl_trunk_sep2024": (669, 1, 0.2)}  # rows, sequences, |u|
    firsts = {"asl_trunk_oct2024": "observations_steady_state_beta_seed0.csv",
              "asl_trunk_sep2024": "steady_state_ik_y-up_200g.csv"}  # fmt: skip
    for name, (n_rows, n_sequences, u_abs) in expected.items():
        out = tmp_path / f"{name}.csv"
        assert main(shipped_command(name, out)) == 0
        assert out.read_bytes() == (ROOT / "data" / f"{name}.csv").read_bytes()
        u, y, meta = read_dataset(out)
        assert (len(u), len(meta["sequence_starts"])) == (n_rows, n_sequences)
        assert meta["robot"]["kind"] == "measured" and meta["units"] == {"u": "effort", "xyz": "m"}
        assert meta["licence"].startswith("MIT") and "trunk-stack" in meta["source"]
        assert np.abs(u).max() == pytest.approx(u_abs, abs=1e-3) and meta["robot"]["u_max"] == u.max(axis=0).tolist()
        raw = np.loadtxt(RAW / firsts[name], delimiter=",", skiprows=1)
        np.testing.assert_array_equal(y[0], raw[0, -3:])  # the tip: x3, y3, z3
        for group in meta["row_groups"]:
            for source in group["sources"]:
                assert hashlib.sha256((ROOT / source["path"]).read_bytes()).hexdigest() == source["sha256"]
    oct_meta = json.loads((tmp_path / "asl_trunk_oct2024.csv.json").read_text())
    assert sum(g["stop"] - g["start"] for g in oct_meta["row_groups"]) == 3489
    assert [g["join"] for g in oct_meta["row_groups"]].count("row") == 3  # the uniform pt1..3 observations
    assert oct_meta["robot"]["u_min"][0] == pytest.approx(-0.637, abs=1e-3)
    assert "imported 3489 rows in 28 sequence(s) from 28 pair(s)" in capsys.readouterr().out


def test_command_end_to_end(tmp_path):
    write(tmp_path, "in.csv", "ID,m1,m2,m3\n0,0.1,0.2,0.3\n1,0.4,0.5,0.6\n2,0.7,0.8,0.9\n")
    write(tmp_path, "obs.csv", "ID,px,py,pz\n2,120,220,320\n0,100,200,300\n")
    argv = ["in.csv", "--observations", "obs.csv", "--id", "ID", "--u", "m1,m2,m3", "--y", "px,py,pz"]
    argv += ["--y-unit", "mm", "--u-unit", "mm", "--licence", "CC0", "--source", "a test", "--out", "mine.csv"]
    r = subprocess.run(
        [sys.executable, "-m", "lab", "import-data", *argv],
        cwd=tmp_path,
        env=subprocess_env(),
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 0, r.stderr
    assert "imported 2 rows in 1 sequence(s) from 1 pair(s) (rows dropped: 1 unmatched_id)" in r.stdout
    u, y, meta = read_dataset(tmp_path / "mine.csv")
    np.testing.assert_allclose(u, [[0.1, 0.2, 0.3], [0.7, 0.8, 0.9]])
    np.testing.assert_allclose(y, [[0.1, 0.2, 0.3], [0.12, 0.22, 0.32]])
    assert meta["robot"] == {"name": "mine", "kind": "measured", "n_motors": 3, "u_min": [0.1, 0.2, 0.3],
                             "u_max": [0.7, 0.8, 0.9], "u_unit": "mm", "y_unit": "m"}  # fmt: skip
    assert meta["licence"] == "CC0" and meta["source"] == "a test" and meta["sequence_starts"] == [0]
    assert meta["command"].startswith("python -m lab import-data in.csv --observations obs.csv")
    assert not list(tmp_path.glob("*.lock")) and not list(tmp_path.glob(".*.tmp*"))
