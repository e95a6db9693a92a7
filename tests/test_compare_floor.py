"""compare --floor tells a report's data by the CSV's content hash (not its path), and
compare refuses a history K that train and splits refuse (one shared rule)."""

import json
import shutil

import numpy as np
import pytest
from test_group_split_balance import unequal_dataset

from lab.cli import main


def plain_csv(path, shift_m=0.0):
    """120 rows (60 commands measured twice, 1 mm noise) as a CSV without a sidecar."""
    rng = np.random.default_rng(0)
    u = np.tile(rng.uniform(0, 1, (60, 2)), (2, 1))
    y = 0.05 * np.column_stack([np.sin(u[:, 0]), np.cos(u[:, 1]), u[:, 0] * u[:, 1]])
    y = y + 1e-3 * rng.standard_normal(y.shape) + [shift_m, 0, 0]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("u0,u1,x,y,z\n" + "".join(",".join(repr(float(v)) for v in r) + "\n" for r in np.hstack([u, y])))


def inspected(tmp_path):
    """A sidecar-less dataset a/d.csv and its inspect report a/r.json."""
    data, report = tmp_path / "a" / "d.csv", tmp_path / "a" / "r.json"
    plain_csv(data)
    assert main(["inspect", str(data), "--bootstrap", "5", "--no-progress", "--out", str(report)]) == 0
    assert json.loads(report.read_text())["dataset"]["csv_sha256"]  # recorded without a sidecar too
    return data, report


COMPARE = ["compare", "--models", "linear", "--n-splits", "1", "--history", "0", "--jobs", "1", "--no-progress"]


def test_a_report_of_a_changed_csv_is_refused(tmp_path, capsys):
    data, report = inspected(tmp_path)
    plain_csv(data, shift_m=0.01)  # the file changed after its report was made
    capsys.readouterr()
    assert main([*COMPARE, str(data), "--floor", str(report), "--out", str(tmp_path / "c.csv")]) == 2
    err = capsys.readouterr().err
    assert "another dataset than" in err and "or the file changed since" in err, err
    assert not (tmp_path / "c.csv").exists()


def test_the_same_data_in_another_folder_is_accepted(tmp_path, capsys):
    data, report = inspected(tmp_path)
    other = tmp_path / "b" / "d.csv"
    other.parent.mkdir()
    shutil.copy(data, other)
    out = tmp_path / "c.csv"
    assert main([*COMPARE, str(other), "--floor", str(report), "--out", str(out)]) == 0
    floor = json.loads((tmp_path / "c.csv.json").read_text())["floor"]
    assert floor["floor_m"] == pytest.approx(json.loads(report.read_text())["floor"]["floor_m"])


def test_a_report_without_a_hash_is_refused(tmp_path, capsys):
    data, report = inspected(tmp_path)
    r = json.loads(report.read_text())
    r["dataset"]["csv_sha256"] = None  # as inspect wrote for a CSV without a sidecar
    report.write_text(json.dumps(r))
    assert main([*COMPARE, str(data), "--floor", str(report), "--out", str(tmp_path / "c.csv")]) == 2
    assert "records no hash of the data" in capsys.readouterr().err


def test_compare_refuses_the_history_train_refuses(tmp_path, capsys):
    data = tmp_path / "s.csv"
    unequal_dataset(data, [6, 6, 6, 6, 6])
    messages = []
    for argv in (["train", str(data), "--history", "6", "--out", str(tmp_path / "m.npz")],
                 ["compare", "--models", "linear", "--history", "6", "--jobs", "1", str(data), "--out",
                  str(tmp_path / "c.csv")]):  # fmt: skip
        assert main(argv) == 2
        messages.append(capsys.readouterr().err.strip())
    assert messages[0] == messages[1]
    assert "--history 6: the longest measurement sequence" in messages[0] and "K must be below it" in messages[0]
    assert not (tmp_path / "c.csv").exists()
