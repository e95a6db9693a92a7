"""Datasets of several markers and input units; ``simulate --commands``; ``import-data --u-unit``."""

import hashlib
import json
import re

import numpy as np
import pytest

from lab.cli import main
from lab.data import (
    input_units,
    marker_names,
    read_commands,
    read_dataset,
    write_dataset,
)
from lab.data.dataset import DatasetError
from lab.description import load_robot
from lab.errors import InputError

COARSE = ["--n-rings", "1", "--n-axial", "6", "--jobs", "1", "--no-progress"]
#: What the dataset writer wrote for this tip-only dataset before markers existed.
OLD_TIP_ONLY = "u0,u1,x,y,z\n0.5,0.25,0.1,-0.2,0.3\n1.0,0.0,0.125,0.0,-1e-05\n"


def test_tip_only_dataset_is_written_as_before(tmp_path):
    u, y = np.array([[0.5, 0.25], [1.0, 0.0]]), np.array([[0.1, -0.2, 0.3], [0.125, 0.0, -1e-05]])
    write_dataset(tmp_path / "d.csv", u, y, {})
    assert (tmp_path / "d.csv").read_text() == OLD_TIP_ONLY
    meta = json.loads((tmp_path / "d.csv.json").read_text())
    assert meta["units"] == {"u": "rad", "xyz": "m"} and meta["input_units"] == ["rad", "rad"]
    assert meta["markers"] == ["tip"] and meta["columns"] == ["u0", "u1", "x", "y", "z"]
    u2, y2, meta2 = read_dataset(tmp_path / "d.csv")
    assert y2.shape == (2, 3) and marker_names(meta2) == ("tip",) and input_units(meta2, 2) == ("rad", "rad")
    # an old file without a sidecar reads as it always did
    (tmp_path / "old.csv").write_text(OLD_TIP_ONLY)
    u3, y3, meta3 = read_dataset(tmp_path / "old.csv")
    assert meta3 == {} and marker_names(meta3) == ("tip",) and np.array_equal(y3, y)


def test_several_markers_round_trip(tmp_path):
    rng = np.random.default_rng(0)
    u, y = rng.random((5, 2)), rng.normal(size=(5, 9))
    write_dataset(tmp_path / "d.csv", u, y, {}, markers=("tip", "ring", "stalk"), units=("N", "N"))
    header = (tmp_path / "d.csv").read_text().splitlines()[0]
    assert header == "u0,u1,x,y,z,ring_x,ring_y,ring_z,stalk_x,stalk_y,stalk_z"
    u2, y2, meta = read_dataset(tmp_path / "d.csv")
    assert np.array_equal(u2, u) and np.array_equal(y2, y)
    assert marker_names(meta) == ("tip", "ring", "stalk")
    assert meta["units"] == {"u": ["N", "N"], "xyz": "m"} and input_units(meta, 2) == ("N", "N")
    # without a sidecar, the names come from the header
    (tmp_path / "d.csv.json").unlink()
    assert marker_names(read_dataset(tmp_path / "d.csv")[2]) == ("tip", "ring", "stalk")
    with pytest.raises(InputError, match="y \\(N, 9\\)"):
        write_dataset(tmp_path / "e.csv", u, y[:, :6], {}, markers=("tip", "ring", "stalk"))
    with pytest.raises(InputError, match="named twice"):
        write_dataset(tmp_path / "e.csv", u, y, {}, markers=("tip", "ring", "ring"))


@pytest.mark.parametrize(
    "header, words",
    [
        ("u0,x,y,q", "column 4 ('q')"),
        ("u0,x,y,z,a_x,a_y,b_z", "column 7 ('b_z')"),
        ("u0,x,y,z,a_x,a_y", "too few columns"),
        ("u0,x,y,z,tip_x,tip_y,tip_z", "named twice"),
        ("x,y,z", "no input column u0"),
    ],
)
def test_bad_marker_header_names_the_column(tmp_path, header, words):
    n = len(header.split(","))
    (tmp_path / "d.csv").write_text(header + "\n" + ",".join(["1"] * n) + "\n")
    with pytest.raises(DatasetError, match=words.replace("(", "\\(").replace(")", "\\)")):
        read_dataset(tmp_path / "d.csv")


def test_sidecar_markers_must_match_the_header(tmp_path):
    write_dataset(tmp_path / "d.csv", np.zeros((1, 1)), np.zeros((1, 6)), {}, markers=("tip", "a"))
    side = tmp_path / "d.csv.json"
    meta = json.loads(side.read_text())
    meta["markers"] = ["tip", "b"]
    side.write_text(json.dumps(meta))
    with pytest.raises(DatasetError, match="differ from its sidecar"):
        read_dataset(tmp_path / "d.csv")


# --- simulate --commands ------------------------------------------------------------------------

COMMANDS = "lower-right,u0,u1\n0.5,0.2,0.0\n0.0,0.0,0.0\n1.0,0.0,0.5\n0.2,0.2,0.2\n0.3,0.9,0.1\n"


def _commands(tmp_path, text=COMMANDS):
    (tmp_path / "U.csv").write_text(text)
    return str(tmp_path / "U.csv")


def test_read_commands_maps_names_to_the_inputs_order(tmp_path):
    robot = load_robot("three-cable")
    u, source = read_commands(_commands(tmp_path), robot)
    assert robot.cables[2].name == "lower-right"
    np.testing.assert_array_equal(u[0], [0.2, 0.0, 0.5])
    np.testing.assert_array_equal(u[:, 2], [0.5, 0.0, 1.0, 0.2, 0.3])  # the file's row order
    assert source["columns"] == ["u0", "u1", "lower-right"] and source["n"] == 5


@pytest.mark.parametrize(
    "text, words",
    [
        ("u0,u1,u2,u9\n0,0,0,0\n", "column 4 ('u9') names no input"),
        ("u0,u1\n0,0\n", "no column for input(s) u2"),
        ("u0,u1,u2,lower-right\n0,0,0,0\n", "both give input u2"),
        ("u0,u1,u2\n0,0,0\n0,nan,0\n", "line 3, column 'u1'"),
        ("u0,u1,u2\n0,0,0\n0,abc,0\n", "line 3, column 'u1': 'abc' is not a number"),
        ("u0,u1,u2\n0,0,0\n0,0,9.5\n", "line 3, column 'u2'"),
        ("u0,u1,u2\n0,0,0\n-0.5,0,0\n", "line 3, column 'u0'"),
    ],
)
def test_bad_commands_files_are_refused_naming_line_and_column(tmp_path, text, words):
    with pytest.raises(InputError, match=re.escape(words)):
        read_commands(_commands(tmp_path, text), load_robot("three-cable"))


def test_simulate_commands_keeps_the_order_and_resumes(tmp_path, capsys):
    u_file = _commands(tmp_path)
    out = tmp_path / "o.csv"
    argv = ["simulate", "--commands", u_file, "--out", str(out), "--chunk-size", "2", *COARSE]
    assert main(argv) == 0
    u, y, meta = read_dataset(out)
    expected, _ = read_commands(u_file, load_robot("three-cable"))
    np.testing.assert_array_equal(u, expected)  # the given order, never reordered
    assert meta["sampler"]["name"] == "commands" and meta["sampler"]["order"] == "as given"
    assert meta["sampler"]["sha256"] == hashlib.sha256((tmp_path / "U.csv").read_bytes()).hexdigest()
    # the same commands in a direct FEM solve: each row is that command's equilibrium
    from lab.data.simulation import solve_chunk

    direct = solve_chunk(load_robot("three-cable"), 1, 6, expected[:2])
    np.testing.assert_allclose(y[:2], direct["p_tip_W"], atol=1e-9)
    # resume: keep the first chunk of a checkpoint, run again, the same numbers
    from lab.data.chunks import ordered_chunks
    from lab.data.chunkstore import ChunkStore, fingerprint

    robot = load_robot("three-cable")
    orders = [c.order for c in ordered_chunks(len(expected), 2)]
    store = ChunkStore(tmp_path / "o2.csv.chunks", fingerprint(robot.sha256, 1, 6, expected, orders))
    store.save(0, {"order": orders[0], "u_motor": expected[orders[0]], **direct})
    assert main([*argv[:4], str(tmp_path / "o2.csv"), *argv[5:]]) == 0
    assert "resumed: 2 samples" in capsys.readouterr().err
    u2, y2, _ = read_dataset(tmp_path / "o2.csv")
    np.testing.assert_array_equal(u2, u)
    np.testing.assert_array_equal(y2, y)
    assert not (tmp_path / "o2.csv.chunks").exists()


def test_simulate_commands_refuses_sampling_flags(tmp_path, capsys):
    argv = ["simulate", "--commands", _commands(tmp_path), "--grid", "3", "--out", str(tmp_path / "o.csv")]
    assert main(argv) == 2
    assert "--grid is not used with --commands" in capsys.readouterr().err
    assert not (tmp_path / "o.csv").exists()


def test_simulate_robot_with_interior_markers_writes_every_marker(tmp_path):
    """Needs the bodies' markers (CylinderBody.markers() returning the description's)."""
    from lab.description.load import ROBOTS_DIR

    text = (ROBOTS_DIR / "three-cable.toml").read_text()
    text += '\n[[markers]]\nname = "mid"\nposition_m = [0.1, 0.0, 0.0]\n'
    text += '\n[[markers]]\nname = "ring"\nposition_m = [0.15, 0.005, 0.0]\n'
    (tmp_path / "r.toml").write_text(text)
    out = tmp_path / "o.csv"
    argv = ["simulate", "--robot", str(tmp_path / "r.toml"), "--commands", _commands(tmp_path), "--out", str(out)]
    assert main([*argv, *COARSE]) == 0
    u, y, meta = read_dataset(out)
    assert y.shape == (5, 9) and marker_names(meta) == ("tip", "mid", "ring")


# --- import-data --u-unit -------------------------------------------------------------------------

TENSIONS = "T1,T2,x,y,z,ring_x,ring_y,ring_z\n1.5,2,10,20,30,1,2,3\n0,3,11,21,31,4,5,6\n"


def test_import_tensions_in_newtons_with_a_marker(tmp_path):
    (tmp_path / "t.csv").write_text(TENSIONS)
    out = tmp_path / "o.csv"
    argv = ["import-data", str(tmp_path / "t.csv"), "--u", "T1,T2", "--u-unit", "N", "--y-unit", "mm"]
    assert main([*argv, "--y", "x,y,z,ring_x,ring_y,ring_z", "--out", str(out)]) == 0
    u, y, meta = read_dataset(out)
    np.testing.assert_array_equal(u, [[1.5, 2.0], [0.0, 3.0]])
    np.testing.assert_allclose(y[0], [0.01, 0.02, 0.03, 0.001, 0.002, 0.003])
    assert marker_names(meta) == ("tip", "ring") and input_units(meta, 2) == ("N", "N")
    assert meta["units"] == {"u": "N", "xyz": "m"}


@pytest.mark.parametrize("unit, factor, si", [("kPa", 1e3, "Pa"), ("bar", 1e5, "Pa"), ("mL", 1e-6, "m^3")])
def test_import_converts_pressures_and_volumes_to_si(tmp_path, unit, factor, si):
    (tmp_path / "t.csv").write_text(TENSIONS)
    out = tmp_path / "o.csv"
    assert main(["import-data", str(tmp_path / "t.csv"), "--u", "T1,T2", "--u-unit", unit, "--y", "x,y,z",
                 "--y-unit", "mm", "--out", str(out)]) == 0  # fmt: skip
    u, _, meta = read_dataset(out)
    np.testing.assert_allclose(u, np.array([[1.5, 2.0], [0.0, 3.0]]) * factor)
    assert input_units(meta, 2) == (si, si) and meta["import"]["u_unit_read"] == unit


@pytest.mark.parametrize(
    "cells, flags, words",
    [
        ("-5,2", ["--u-unit", "N"], "line 2, column 'T1' (--u): -5 N is not plausible for a tension"),
        ("1,2", ["--u-unit", "N", "--robot", "three-cable"], "has 3 inputs"),
        ("1,2", ["--u-unit", "N,furlong"], "not 'furlong'"),
    ],
)
def test_import_refuses_implausible_or_mismatched_units(tmp_path, capsys, cells, flags, words):
    (tmp_path / "t.csv").write_text(TENSIONS.replace("1.5,2", cells))
    out = tmp_path / "o.csv"
    argv = ["import-data", str(tmp_path / "t.csv"), "--u", "T1,T2", "--y", "x,y,z", *flags, "--out", str(out)]
    assert main(argv) == 2
    assert words in capsys.readouterr().err
    assert not out.exists()


def test_import_unit_must_be_the_robots_kind(tmp_path, capsys):
    (tmp_path / "t.csv").write_text("a,b,c,x,y,z\n0.1,0.2,0.3,1,2,3\n")
    argv = ["import-data", str(tmp_path / "t.csv"), "--u", "a,b,c", "--y", "x,y,z", "--robot", "three-cable"]
    assert main([*argv, "--u-unit", "N", "--out", str(tmp_path / "o.csv")]) == 2
    assert "'N' is a tension, but input u0" in capsys.readouterr().err
    assert main([*argv, "--out", str(tmp_path / "o.csv")]) == 0  # rad: the robot's
    assert read_dataset(tmp_path / "o.csv")[2]["robot"]["description"]["name"] == "three-cable"


def test_splits_on_a_multi_marker_dataset(tmp_path):
    rng = np.random.default_rng(1)
    u = rng.random((40, 2))
    y = np.column_stack([u @ rng.normal(size=(2, 3)), u @ rng.normal(size=(2, 3))]) * 0.01
    write_dataset(tmp_path / "d.csv", u, y, {}, markers=("tip", "ring"))
    out = tmp_path / "s.csv"
    argv = ["splits", str(tmp_path / "d.csv"), "--hidden", "3", "--epochs", "3", "--n-splits", "2", "--jobs", "1"]
    assert main([*argv, "--out", str(out)]) == 0
    assert out.exists()
