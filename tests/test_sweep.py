"""The fault sweep: bad input, faults and interruptions against the command line.

One row per case (tests/sweep.py: command, exit code, words of the message, files that
must be unchanged). Every case also checks that no traceback is shown and no temporary
file is left. Mechanism tests that do not fit a row follow the table.
"""

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from filelock import FileLock
from helpers import subprocess_env, wait_until
from sweep import COARSE, ROOT, Case, run_case
from sweep_bodies import BODY_CASES
from sweep_chambers import CHAMBER_CASES
from sweep_compare import COMPARE_CASES
from sweep_defects import DEFECTS_CASES
from sweep_description_units import DESCRIPTION_UNIT_CASES
from sweep_designs import DESIGNS_CASES
from sweep_edition import EDITION_CASES
from sweep_foam import FOAM_CASES
from sweep_history import HISTORY_CASES
from sweep_import import IMPORT_CASES
from sweep_inspect import INSPECT_CASES
from sweep_pneumatic import PNEUMATIC_CASES
from sweep_progress import PROGRESS_CASES
from sweep_realtime import REALTIME_CASES
from sweep_rig_none import RIG_NONE_CASES
from sweep_times import TIMES_CASES
from sweep_training import TRAINING_CASES
from sweep_units import UNITS_CASES

SIM = ["simulate", "--grid", "2", "--jobs", "1", "--no-progress", *COARSE]
TRAIN = ["train", "{dir}/data.csv", "--hidden", "3", "--epochs", "3"]
SPLITS = ["splits", "{dir}/data.csv", "--hidden", "3", "--n-splits", "2", "--jobs", "1"]
TRACK = ["track", "--model", "{dir}/model.npz", "--trajectory", "{dir}/traj.csv", *COARSE]
CAPTURE = ["capture", "--rig", "twin", "--grid", "2", "--no-progress"]
DATA_CURVE = ["data-curve", "--n-rings", "1", "--n-axial", "4", "--heldout", "12", "--epochs", "3", "--no-tracking",
              "--samples-per-hour", "300", "--jobs", "1", "--strategies", "random"]  # fmt: skip
#: A data-curve file of one row, as `data-curve ... --ns 8` writes it.
CURVE_ROW = (
    "robot,rig,rig_spec,strategy,n,grid_levels,seed,model,model_error_m,circle_m,square_m,rose_m,tracking_mean_m,"
    "fit_s,design_s,capture_h,heldout_id\nthree-cable,FEM,sim,random,8,,0,mlp,0.02,nan,nan,nan,nan,0.1,0.1,0.02,ab\n"
)
INPUTS = ("{dir}/data.csv", "{dir}/data.csv.json", "{dir}/model.npz", "{dir}/robot.toml", "{dir}/traj.csv")
#: A points file of two measured points, as an interrupted `track` on the three-cable arm leaves it.
KEPT_POINTS = (
    "i,target_x,target_y,target_z,u0,u1,u2,x,y,z,settled,wait_s\n"
    "0,0.18,0.0,-0.01,1.0,1.0,1.0,0.18,0.0,-0.01,1,2.0\n1,0.18,0.01,-0.01,1.0,1.2,0.8,0.18,0.01,-0.01,1,2.0\n"
)


def edit(name, old, new):
    """A setup that replaces ``old`` by ``new`` in the case's copy of ``name``."""

    def setup(d: Path):
        p = d / name
        text = p.read_text()
        assert old in text, f"{name} has no {old!r}"
        p.write_text(text.replace(old, new, 1))

    return setup


def write(name, text):
    def setup(d: Path):
        (d / name).parent.mkdir(parents=True, exist_ok=True)
        (d / name).write_text(text)

    return setup


def both(*setups):
    def setup(d: Path):
        for s in setups:
            s(d)

    return setup


def dataset_of(rows):
    def setup(d: Path):
        from lab.data import write_dataset

        u = np.asarray(rows, float)
        write_dataset(d / "small.csv", u, 0.01 * u, {"note": "tiny"})

    return setup


def exists(path, yes=True):
    def after(d: Path):
        assert (Path(str(path).replace("{dir}", str(d))).exists()) == yes, f"{path} exists: {not yes}"

    return after


def rig_config(d: Path):
    (d / "rig.toml").write_text((ROOT / "lab" / "rigs" / "hardware-example.toml").read_text())


def dynamic_model(metadata: str | None):
    """A setup writing ``dyn.npz``: empty (``None``) or a dynamic model with this metadata text."""

    def setup(d: Path):
        if metadata is None:
            (d / "dyn.npz").write_bytes(b"")
        else:
            np.savez(d / "dyn.npz", metadata=np.array(metadata), tau_s=np.array([0.5]), weight=np.array([[1.0]]))

    return setup


def scaled_tips(name, scale=1.0, shift_m=(0.0, 0.0, 0.0), n=12):
    """A setup writing ``name``: the first ``n`` samples of data.csv, tips times ``scale`` plus ``shift_m``."""

    def setup(d: Path):
        from lab.data import read_dataset, write_dataset

        u, y, meta = read_dataset(d / "data.csv")
        write_dataset(d / name, u[:n], scale * y[:n] + np.asarray(shift_m), {"robot": meta.get("robot")})

    return setup


def tendon_robot(path: Path):
    """The three-cable description with its cables pulled by tension (3 N at most), no [actuation]."""
    import re

    text = (ROOT / "lab" / "robots" / "three-cable.toml").read_text()
    text = re.sub(r"\[actuation\].*?(?=\[\[cables\]\])", "", text, flags=re.S)
    text = re.sub(r"\[\[safety\.limits\]\].*", "", text, flags=re.S).replace('"three-cable"', '"three-tendon"')
    stations = "stations_m = [0.04, 0.08, 0.12, 0.16, 0.20]\n"
    path.write_text(text.replace(stations, stations + 'control = "tension"\ntension_max_n = 3.0\n'))


def cut_short(name, keep_fields=True):
    """A setup writing ``name`` (no sidecar): data.csv cut within its last number (or, with
    ``keep_fields=False``, after its second-last comma), without the final newline."""

    def setup(d: Path):
        text = (d / "data.csv").read_text().rstrip("\n")
        (d / name).write_text(text[:-3] if keep_fields else text[: text.rfind(",")])

    return setup


def four_motor_dataset(d: Path):
    from lab.data import write_dataset

    write_dataset(d / "four.csv", np.full((8, 4), 0.1), np.zeros((8, 3)), {"robot": {"name": "three-cable"}})


def four_input_model(d: Path):
    from lab.learn.mlp import MLP

    MLP([np.zeros((2, 4)), np.zeros((3, 2))], [np.zeros(2), np.zeros(3)], np.zeros(4), np.ones(4), np.zeros(3),
        np.ones(3)).save(d / "four.npz")  # fmt: skip


def curve_file(**settings):
    """A setup writing ``tc.csv``: one transfer-curve row, its sidecar made with ``settings``
    (TransferCurveSpec fields; ``--sim-model`` {dir}/model.npz unless given)."""

    def setup(d: Path):
        from lab.studies.transfer_curve import COLUMNS, TransferCurveSpec

        spec = TransferCurveSpec(**{"sim_model": str(d / "model.npz"), **settings})
        row = {c: "0.01" for c in COLUMNS} | {"robot": "random:0", "method": "real-only", "n_real": "5"}
        (d / "tc.csv").write_text(",".join(COLUMNS) + "\n" + ",".join(row[c] for c in COLUMNS) + "\n")
        meta = {"kind": "lab.transfer_curve", "robot": spec.robot, "sim_model": spec.sim_model, **spec.settings()}
        (d / "tc.csv.json").write_text(json.dumps(meta))

    return setup


_held = {}


def hold_lock(path):
    def setup(d: Path):
        lock = FileLock(str(d / path) + ".lock", timeout=0)
        lock.acquire()
        _held["lock"] = lock

    return setup


CASES = [
    # --- 0. inputs that are not what they claim to be: binary files, broken metadata ----------
    Case(
        "robot-toml-not-utf8",
        [*SIM, "--robot", "{dir}/model.npz", "--out", "{dir}/o.csv"],
        2,
        ("model.npz", "not UTF-8"),
        ("{dir}/model.npz",),
        absent=("{dir}/o.csv",),
    ),
    Case(
        "defects-toml-not-utf8",
        [*TRACK[:5], "--rig", "twin:{dir}/model.npz", "--out", "{dir}/r.json"],
        2,
        ("model.npz", "not UTF-8"),
        ("{dir}/model.npz",),
        absent=("{dir}/r.json",),
    ),
    Case(
        "hardware-config-not-utf8",
        ["capture", "--rig", "hardware:{dir}/model.npz", "--grid", "2", "--out", "{dir}/o.csv"],
        2,
        ("model.npz", "not UTF-8"),
        ("{dir}/model.npz",),
        absent=("{dir}/o.csv",),
    ),
    *(
        Case(
            f"{cmd}-dynamic-model-{name}",
            [*argv, "--dynamic-model", "{dir}/dyn.npz", "--out", "{dir}/o.json"],
            2,
            ("dyn.npz", words),
            ("{dir}/dyn.npz",),
            absent=("{dir}/o.json",),
            setup=dynamic_model(metadata),
        )
        for cmd, argv in (
            ("track", [*TRACK[:5], "--rig", "twin", "--period-s", "5"]),
            ("capture", [*CAPTURE, "--protocol", "predictive"]),
        )
        for name, metadata, words in (
            ("empty", None, "not a readable dynamic-model file"),
            ("list-metadata", "[1, 2]", "metadata must be a JSON object"),
            ("text-version", '{"kind": "lab.dynamics", "format_version": "x"}', "format_version must be an integer"),
        )
    ),
    # --- 1. checkpoints: only what the run made is ever deleted ---------------------------
    Case(
        "checkpoint-with-foreign-files",
        [*SIM, "--checkpoint", "{dir}/mine", "--out", "{dir}/o.csv"],
        2,
        ("holds files that are not a lab checkpoint", "notes.txt", "nothing was deleted"),
        unchanged=("{dir}/mine/notes.txt",),
        absent=("{dir}/o.csv",),
        setup=write("mine/notes.txt", "my notes"),
    ),
    Case(
        "restart-with-foreign-files",
        [*SIM, "--restart", "--checkpoint", "{dir}/mine", "--out", "{dir}/o.csv"],
        2,
        ("holds files that are not a lab checkpoint",),
        unchanged=("{dir}/mine/notes.txt",),
        setup=write("mine/notes.txt", "my notes"),
    ),
    Case(
        "checkpoint-dir-the-user-made-survives",
        [*SIM, "--checkpoint", "{dir}/mine", "--out", "{dir}/o.csv"],
        0,
        setup=lambda d: (d / "mine").mkdir(),
        after=exists("{dir}/mine"),
    ),
    Case(
        "own-checkpoint-removed-after-success",
        [*SIM, "--out", "{dir}/o.csv"],
        0,
        after=exists("{dir}/o.csv.chunks", False),
    ),
    # --- 2. an output is never one of the inputs ------------------------------------------
    Case("train-out-is-data", [*TRAIN, "--out", "{dir}/data.csv"], 2, ("is the input DATA", "refusing"), INPUTS),
    Case(
        "train-report-is-data",
        [*TRAIN, "--out", "{dir}/m.npz", "--report", "{dir}/data.csv"],
        2,
        ("--report", "is the input DATA"),
        INPUTS,
    ),
    Case(
        "train-report-is-out",
        [*TRAIN, "--out", "{dir}/m.npz", "--report", "{dir}/m.npz"],
        2,
        ("same file as --out",),
        INPUTS,
        absent=("{dir}/m.npz",),
    ),
    Case("train-out-is-sidecar", [*TRAIN, "--out", "{dir}/data.csv.json"], 2, ("DATA sidecar",), INPUTS),
    Case("splits-out-is-data", [*SPLITS, "--out", "{dir}/data.csv"], 2, ("is the input DATA",), INPUTS),
    Case(
        "simulate-out-is-robot",
        [*SIM, "--robot", "{dir}/robot.toml", "--out", "{dir}/robot.toml"],
        2,
        ("is the input --robot",),
        INPUTS,
    ),
    Case(
        "simulate-sidecar-is-robot",
        [*SIM, "--robot", "{dir}/r.toml.json", "--out", "{dir}/r.toml"],
        2,
        ("--out sidecar", "is the input --robot"),
        setup=write("r.toml.json", "x"),
        unchanged=("{dir}/r.toml.json",),
    ),
    Case("track-out-is-trajectory", [*TRACK, "--out", "{dir}/traj.csv"], 2, ("is the input --trajectory",), INPUTS),
    Case("track-out-is-model", [*TRACK, "--out", "{dir}/model.npz"], 2, ("is the input --model",), INPUTS),
    Case(
        "capture-journal-is-out",
        [*CAPTURE, "--journal", "{dir}/c.csv", "--out", "{dir}/c.csv"],
        2,
        ("same file as --out",),
        absent=("{dir}/c.csv",),
    ),
    Case(
        "capture-out-is-defects",
        [*CAPTURE[:2], "twin:{dir}/d.toml", *CAPTURE[3:], "--out", "{dir}/d.toml"],
        2,
        ("is the input --rig",),
        setup=write("d.toml", "x"),
        unchanged=("{dir}/d.toml",),
    ),
    Case(
        "simulate-lock-file-is-robot",
        [*SIM, "--robot", "{dir}/o.csv.lock", "--out", "{dir}/o.csv"],
        2,
        ("--out lock", "is the input --robot"),
        setup=lambda d: (d / "o.csv.lock").write_text((d / "robot.toml").read_text()),
        unchanged=("{dir}/o.csv.lock",),
    ),
    # --- 3./12. a dataset and its sidecar belong together --------------------------------
    Case(
        "last-number-cut-short",
        [*TRAIN, "--out", "{dir}/m.npz"],
        2,
        ("does not match its sidecar",),
        setup=lambda d: (d / "data.csv").write_text((d / "data.csv").read_text()[:-3] + "\n"),
        absent=("{dir}/m.npz",),
    ),
    Case(
        "sidecar-is-a-list",
        [*TRAIN, "--out", "{dir}/m.npz"],
        2,
        ("must be a JSON object",),
        setup=write("data.csv.json", "[1, 2]"),
    ),
    Case(
        "disk-full-over-an-existing-dataset",
        [*SIM[:2], "4", *SIM[3:], "--out", "{dir}/data.csv"],
        1,
        ("no space left to write", "File too large", "unchanged"),
        ("{dir}/data.csv", "{dir}/data.csv.json"),
        limit_file_kib=4,
        timeout_s=240,
    ),
    Case(
        "disk-full-writing-a-chunk",
        [*SIM[:2], "4", *SIM[3:], "--out", "{dir}/data.csv"],
        1,
        ("no space left to write", "File too large", "finished chunks are kept"),
        ("{dir}/data.csv", "{dir}/data.csv.json"),
        limit_file_kib=1,
        timeout_s=240,
    ),
    # a checkpoint that cannot be made fails before any work, not after the first chunk
    Case(
        "checkpoint-is-a-file",
        [*SIM, "--checkpoint", "{dir}/data.csv", "--out", "{dir}/o.csv"],
        2,
        ("--checkpoint", "is a file, not a directory"),
        ("{dir}/data.csv",),
        absent=("{dir}/o.csv",),
    ),
    Case(
        "checkpoint-under-a-file",
        [*SIM, "--checkpoint", "{dir}/data.csv/ck", "--out", "{dir}/o.csv"],
        2,
        ("--checkpoint", "data.csv is a file, not a directory"),
        ("{dir}/data.csv",),
        absent=("{dir}/o.csv",),
    ),
    # --- 5. unwritable outputs are refused before any work ---------------------------------
    Case("out-is-a-directory", [*SIM, "--out", "{dir}"], 2, ("is a directory",)),
    Case("out-under-a-file", [*SIM, "--out", "{dir}/data.csv/o.csv"], 2, ("is a file, not a directory",), INPUTS),
    Case("train-out-under-a-file", [*TRAIN, "--out", "{dir}/traj.csv/m.npz"], 2, ("is a file",), INPUTS),
    Case("track-out-is-a-directory", [*TRACK, "--out", "{dir}"], 2, ("is a directory",), INPUTS),
    Case("capture-out-under-a-file", [*CAPTURE, "--out", "{dir}/model.npz/c.csv"], 2, ("is a file",), INPUTS),
    Case(
        "robot-is-a-directory", [*SIM, "--robot", "{dir}", "--out", "{dir}/o.csv"], 2, ("is a directory, not a file",)
    ),
    Case("train-data-is-a-directory", ["train", "{dir}", "--out", "{dir}/m.npz"], 2, ("is a directory",)),
    # --- 7. one run per output ---------------------------------------------------------------
    Case(
        "simulate-output-locked",
        [*SIM, "--out", "{dir}/o.csv"],
        2,
        ("being written by another run",),
        setup=hold_lock("o.csv"),
        absent=("{dir}/o.csv",),
    ),
    Case(
        "capture-journal-locked",
        [*CAPTURE, "--out", "{dir}/c.csv"],
        2,
        ("c.journal.csv is being written by another process",),
        setup=hold_lock("c.journal.csv"),
        unchanged=("{dir}/c.journal.csv.lock",),  # the holder's lock file stays
        absent=("{dir}/c.csv",),
    ),
    Case(
        "capture-settle-tol-zero",
        [*CAPTURE, "--settle-tol-mm", "0", "--out", "{dir}/c.csv"],
        2,
        ("--settle-tol-mm must be finite and > 0",),
        absent=("{dir}/c.csv", "{dir}/c.journal.csv"),
    ),
    Case(
        "capture-predictive-without-reset",
        [*CAPTURE, "--protocol", "predictive", "--no-reset", "--out", "{dir}/c.csv"],
        2,
        ("--protocol predictive", "--no-reset"),
        absent=("{dir}/c.csv", "{dir}/c.journal.csv"),
    ),
    # --- 8. unknown fields are refused, with the closest name ----------------------------
    Case(
        "robot-misspelt-field",
        [*SIM, "--robot", "{dir}/robot.toml", "--out", "{dir}/o.csv"],
        2,
        ("[material] has no field 'youngs_modulus_kpa'", "did you mean 'youngs_modulus_pa'?", "robot.toml"),
        ("{dir}/robot.toml",),
        setup=edit("robot.toml", "youngs_modulus_pa", "youngs_modulus_kpa"),
    ),
    Case(
        "robot-unknown-top-level",
        [*SIM, "--robot", "{dir}/robot.toml", "--out", "{dir}/o.csv"],
        2,
        ("has no field 'colour'",),
        setup=edit("robot.toml", 'name = "three-cable"', 'name = "x"\ncolour = "red"'),
    ),
    Case(
        "robot-cable-misspelt",
        [*SIM, "--robot", "{dir}/robot.toml", "--out", "{dir}/o.csv"],
        2,
        ("[cables[0]] has no field 'station_m'", "did you mean 'stations_m'?"),
        setup=edit("robot.toml", "stations_m", "station_m"),
    ),
    Case(
        "defects-misspelt-field",
        [*CAPTURE[:2], "twin:{dir}/defects.toml", *CAPTURE[3:], "--out", "{dir}/c.csv"],
        2,
        ("[lag] has no field 'tau_fast'", "did you mean 'tau_fast_s'?"),
        ("{dir}/defects.toml",),
        setup=edit("defects.toml", "tau_fast_s", "tau_fast"),
    ),
    Case(
        "rig-config-misspelt-field",
        [*TRACK[:-4], "--rig", "hardware:{dir}/rig.toml", "--out", "{dir}/r.json"],
        2,
        ("[servos] has no field 'baudrate'", "did you mean 'baud_rate'?"),
        ("{dir}/rig.toml",),
        setup=both(rig_config, edit("rig.toml", "baud_rate", "baudrate")),
    ),
    # --- 9./10./13. the description is checked where it is read ------------------------------
    Case(
        "tip-marker-outside",
        [*SIM, "--robot", "{dir}/robot.toml", "--out", "{dir}/o.csv"],
        2,
        ("tip_marker.position_m", "outside the body"),
        setup=edit("robot.toml", "position_m = [0.20,", "position_m = [0.30,"),
        absent=("{dir}/o.csv.chunks",),
    ),
    Case(
        "huge-mesh",
        [*SIM[:5], "--n-rings", "3", "--n-axial", "100000000", "--out", "{dir}/o.csv"],
        2,
        ("would need about", "TB of memory", "available"),
    ),
    Case(
        "zero-rings", [*SIM[:5], "--n-rings", "0", "--out", "{dir}/o.csv"], 2, ("--n-rings must be a positive integer",)
    ),
    # --- sampling designs: refused before any work; counts bounded by what the machine holds --
    Case(
        "sobol-huge",
        [SIM[0], *SIM[3:], "--sobol", "1000000000", "--out", "{dir}/o.csv"],
        2,
        ("--design sobol --n 1000000000", "at most 100000"),
        absent=("{dir}/o.csv", "{dir}/o.csv.chunks"),
    ),
    Case("lhs-huge", [SIM[0], *SIM[3:], "--lhs", "200000", "--out", "{dir}/o.csv"], 2, ("at most 100000",)),
    Case(
        "design-n-huge",
        [SIM[0], *SIM[3:], "--design", "random", "--n", "1000000000", "--out", "{dir}/o.csv"],
        2,
        ("--design random --n 1000000000", "at most 100000"),
    ),
    Case(
        "grid-huge",
        [SIM[0], *SIM[3:], "--grid", "100000", "--out", "{dir}/o.csv"],
        2,
        ("--grid 100000", "candidate commands", "at most 4,194,304"),
        absent=("{dir}/o.csv", "{dir}/o.csv.chunks"),
    ),
    Case(
        "active-huge",
        [SIM[0], *SIM[3:], "--active", "1000000000", "--batch", "10", "--out", "{dir}/o.csv"],
        2,
        ("--active must be at most 100000",),
    ),
    Case(
        "active-batch-over-pool",
        [SIM[0], *SIM[3:], "--active", "100", "--batch", "5000", "--out", "{dir}/o.csv"],
        2,
        ("--batch must be at most 4096",),
    ),
    Case(
        "active-initial-too-small",
        [SIM[0], *SIM[3:], "--active", "10", "--batch", "4", "--out", "{dir}/o.csv"],
        2,
        ("--active 10", "too few", "--active 12 or more"),
        absent=("{dir}/o.csv", "{dir}/o.csv.chunks"),
    ),
    Case(
        "capture-active-initial-too-small",
        [*CAPTURE[:3], *CAPTURE[5:], "--active", "10", "--batch", "4", "--out", "{dir}/c.csv"],
        2,
        ("--active 10", "too few"),
        absent=("{dir}/c.csv", "{dir}/c.journal.csv"),
    ),
    Case(
        "chunk-size-zero",
        [SIM[0], *SIM[3:], "--sobol", "4", "--chunk-size", "0", "--out", "{dir}/o.csv"],
        2,
        ("--chunk-size must be a positive integer",),
        absent=("{dir}/o.csv", "{dir}/o.csv.chunks"),
    ),
    Case(
        "safety-limits-not-a-list",
        [*SIM, "--robot", "{dir}/robot.toml", "--out", "{dir}/o.csv"],
        2,
        ("safety.limits", "must be a list of tables"),
        setup=edit(
            "robot.toml",
            "[[safety.limits]]\ncables = [0, 1, 2]\nmax_sum_over_u_max = 2.1666666666666665",
            'limits = "none"',
        ),
    ),
    Case(
        "stations-not-numbers",
        [*SIM, "--robot", "{dir}/robot.toml", "--out", "{dir}/o.csv"],
        2,
        ("stations_m' must hold numbers",),
        setup=edit("robot.toml", "stations_m = [0.04,", 'stations_m = ["a",'),
    ),
    # --- 11. too little data ----------------------------------------------------------------
    Case(
        "train-one-row",
        ["train", "{dir}/small.csv", "--out", "{dir}/m.npz"],
        2,
        ("too few", "need at least 6"),
        setup=dataset_of([[0.1, 0.2, 0.3]]),
        absent=("{dir}/m.npz",),
    ),
    Case(
        "train-identical-rows",
        ["train", "{dir}/small.csv", "--out", "{dir}/m.npz"],
        2,
        ("1 distinct commands",),
        setup=dataset_of([[0.1, 0.2, 0.3]] * 40),
    ),
    Case(
        "splits-one-row",
        ["splits", "{dir}/small.csv", "--jobs", "1", "--out", "{dir}/s.csv"],
        2,
        ("too few",),
        setup=dataset_of([[0.1, 0.2, 0.3]]),
    ),
    Case(
        "train-min-grad-nan",
        [*TRAIN, "--algorithm", "br", "--min-grad", "nan", "--out", "{dir}/m.npz"],
        2,
        ("--min-grad", "finite"),
        absent=("{dir}/m.npz",),
    ),
    Case(
        "train-network-too-big",
        ["train", "{dir}/data.csv", "--hidden", "100000", "100000", "--out", "{dir}/m.npz"],
        2,
        ("--hidden 100000 100000", "of memory"),
        absent=("{dir}/m.npz",),
    ),
    Case(
        "transfer-network-too-big",
        ["transfer", "--method", "real-only", "--real", "{dir}/data.csv", "--hidden", "100000", "--out", "{dir}/m.npz"],
        2,
        ("--hidden 100000:", "of memory"),
        absent=("{dir}/m.npz",),
    ),
    Case("splits-negative-seed", [*SPLITS, "--seed", "-1", "--out", "{dir}/s.csv"], 2, ("--seed", ">= 0")),
    # --- classes that already held -----------------------------------------------------------
    Case("unknown-robot", [*SIM, "--robot", "no-such-robot", "--out", "{dir}/o.csv"], 2, ("unknown robot",)),
    Case("dataset-missing", ["train", "{dir}/none.csv", "--out", "{dir}/m.npz"], 2, ("dataset not found",)),
    Case(
        "dataset-non-numeric",
        [*TRAIN, "--out", "{dir}/m.npz"],
        2,
        ("line 3 has a non-numeric value",),
        setup=lambda d: (d / "data.csv").write_text(
            "\n".join(
                line if i != 2 else "a,b,c,d,e,f" for i, line in enumerate((d / "data.csv").read_text().splitlines())
            )
            + "\n"
        ),
        unchanged=("{dir}/model.npz",),
    ),
    Case(
        "model-missing",
        [*TRACK[:2], "{dir}/none.npz", *TRACK[3:], "--out", "{dir}/r.json"],
        2,
        ("model file not found",),
    ),
    Case("model-not-npz", [*TRACK, "--out", "{dir}/r.json"], 2, ("not an .npz",), setup=write("model.npz", "hello")),
    Case(
        "trajectory-bad-header",
        [*TRACK, "--out", "{dir}/r.json"],
        2,
        ("traj.csv",),
        setup=write("traj.csv", "a,b,c\n1,2,3\n"),
        absent=("{dir}/r.json",),
    ),
    Case(
        "defects-missing",
        [*CAPTURE[:2], "twin:{dir}/none.toml", *CAPTURE[3:], "--out", "{dir}/c.csv"],
        2,
        ("defects file not found",),
    ),
    Case(
        "robot-not-toml",
        [*SIM, "--robot", "{dir}/robot.toml", "--out", "{dir}/o.csv"],
        2,
        ("not valid TOML",),
        setup=write("robot.toml", "[body\n"),
    ),
    # --- data-curve: one run per output, a results file that cannot be read, bounded studies ---
    Case(
        "data-curve-output-locked",
        [*DATA_CURVE, "--ns", "8", "--out", "{dir}/dc.csv"],
        2,
        ("being written by another run",),
        setup=hold_lock("dc.csv"),
        absent=("{dir}/dc.csv", "{dir}/dc.csv.json"),
    ),
    Case(
        "data-curve-sidecar-not-json",
        [*DATA_CURVE, "--ns", "8", "--out", "{dir}/dc.csv"],
        2,
        ("{dir}/dc.csv.json", "not valid JSON"),
        ("{dir}/dc.csv", "{dir}/dc.csv.json"),
        setup=both(write("dc.csv", CURVE_ROW), write("dc.csv.json", '{"settings": {')),
    ),
    Case(
        "data-curve-sidecar-a-list",
        [*DATA_CURVE, "--ns", "8", "--out", "{dir}/dc.csv"],
        2,
        ("{dir}/dc.csv.json", "must be a JSON object"),
        ("{dir}/dc.csv", "{dir}/dc.csv.json"),
        setup=both(write("dc.csv", CURVE_ROW), write("dc.csv.json", "[1, 2]")),
    ),
    Case(
        "data-curve-n-not-a-number",
        [*DATA_CURVE, "--ns", "8", "--out", "{dir}/dc.csv"],
        2,
        ("{dir}/dc.csv: line 2", "n 'eight' is not a number"),
        ("{dir}/dc.csv",),
        setup=write("dc.csv", CURVE_ROW.replace(",random,8,", ",random,eight,")),
        absent=("{dir}/dc.csv.json",),
    ),
    Case(
        "data-curve-ns-huge",
        [*DATA_CURVE, "--ns", "8", "1000000000", "--out", "{dir}/dc.csv"],
        2,
        ("--ns must be at most 100000",),
        absent=("{dir}/dc.csv",),
    ),
    Case(
        "data-curve-maximin-over-its-limit",
        [*DATA_CURVE, "maximin", "--ns", "5000", "--out", "{dir}/dc.csv"],
        2,
        ("--ns: a maximin design takes at most 2000",),
    ),
    Case(
        "data-curve-seeds-many",
        [*DATA_CURVE, "--ns", "8", "--seeds", *map(str, range(1001)), "--out", "{dir}/dc.csv"],
        2,
        ("--seeds: at most 1000 seeds",),
        absent=("{dir}/dc.csv",),
    ),
    Case(
        "data-curve-rows-many",
        [*DATA_CURVE, "sobol", "--ns", *map(str, range(1, 5002)), "--out", "{dir}/dc.csv"],
        2,
        ("10,002 rows", "at most 10,000"),
    ),
    Case(
        "data-curve-grid-levels-huge",
        [*DATA_CURVE, "grid", "--grid-levels", "1000", "--ns", "8", "--out", "{dir}/dc.csv"],
        2,
        ("--grid-levels 1000", "candidate commands", "at most 4,194,304"),
    ),
    Case(
        "unknown-rig",
        [*TRACK[:5], "--rig", "warp", "--out", "{dir}/r.json"],
        2,
        ("unknown rig 'warp'",),
        absent=("{dir}/r.json", "{dir}/r.json.points.csv"),
    ),
    # --- track: kept points are never lost or overwritten; one run per output; bounded runs ---
    Case(
        "track-points-file-the-user-wrote",
        [*TRACK, "--out", "{dir}/r.json"],
        2,
        ("{dir}/r.json.points.csv", "not a points file", "nothing was changed"),
        ("{dir}/r.json.points.csv",),
        absent=("{dir}/r.json",),
        setup=write("r.json.points.csv", "my own notes\n"),
    ),
    Case(
        "track-rig-fails-at-once-keeps-points",
        [*TRACK[:-4], "--rig", "hardware:{dir}/rig.toml", "--out", "{dir}/r.json"],
        1,
        ("the 2 points kept from an earlier run are still in {dir}/r.json.points.csv",),
        ("{dir}/r.json.points.csv",),
        absent=("{dir}/r.json",),
        setup=both(rig_config, write("r.json.points.csv", KEPT_POINTS)),
    ),
    Case(
        "track-output-locked",
        [*TRACK, "--closed-loop", "ilc", "--out", "{dir}/r.json"],
        2,
        ("being written by another run",),
        absent=("{dir}/r.json", "{dir}/r.json.points.csv"),
        setup=hold_lock("r.json"),
    ),
    Case(
        "track-stream-max-spread-negative",
        [*TRACK, "--period-s", "2", "--max-spread-mm", "-1", "--out", "{dir}/r.json"],
        2,
        ("--max-spread-mm is not used in a streamed run",),
        absent=("{dir}/r.json",),
    ),
    Case(
        "track-stream-ignored-ik-flags",
        [*TRACK, *"--period-s 2 --max-spread-mm 0.001 --spread-weight 5 --reg-weight 1 --out {dir}/r.json".split()],
        2,
        ("--reg-weight, --spread-weight, --max-spread-mm are not used in a streamed run",),
        absent=("{dir}/r.json",),
    ),
    Case(
        "track-stream-passes-ignored",
        [*TRACK, "--period-s", "2", "--passes", "3", "--out", "{dir}/r.json"],
        2,
        ("--passes is not used in a streamed run",),
    ),
    Case(
        "track-soft-ik-max-spread",
        ["track", "--soft-ik", *TRACK[3:], "--max-spread-mm", "1", "--out", "{dir}/r.json"],
        2,
        ("--max-spread-mm is not used with --soft-ik",),
        absent=("{dir}/r.json",),
    ),
    Case(
        "track-lead-in-huge",
        [*TRACK, "--period-s", "2", "--lead-in-s", "1e9", "--out", "{dir}/r.json"],
        2,
        ("--lead-in-s must be at most 600 s",),
        absent=("{dir}/r.json",),
    ),
    Case(
        "track-periods-huge",
        [*TRACK, "--period-s", "2", "--n-periods", "1000000000", "--out", "{dir}/r.json"],
        2,
        ("commands: at most 20000",),
    ),
    Case(
        "track-passes-huge",
        [*TRACK, "--closed-loop", "ilc", "--passes", "1000000", "--out", "{dir}/r.json"],
        2,
        ("--passes must be at most 100",),
        absent=("{dir}/r.json", "{dir}/r.json.points.csv"),
    ),
    Case(
        "track-n-points-huge",
        [*TRACK[:4], "circle", "--n-points", "1000000000", *COARSE, "--out", "{dir}/r.json"],
        2,
        ("--n-points must be at most 10000",),
    ),
    Case(
        "fit-dynamics-step-hold-huge",
        ["fit-dynamics", "--rig", "twin", "--step-hold-s", "1e9", "--out", "{dir}/d.npz"],
        2,
        ("--step-hold-s must be at most 600 s",),
        absent=("{dir}/d.npz",),
    ),
    Case(
        "fit-dynamics-probe-too-long",
        ["fit-dynamics", "--rig", "twin", "--n-steps", "1000", "--step-hold-s", "600", "--out", "{dir}/d.npz"],
        2,
        ("hold the rig up to", "at most 4 h"),
        absent=("{dir}/d.npz",),
    ),
    # --- train, splits, transfer, transfer-curve, calibrate, defects: what each run reads is what it claims -----
    Case(
        "splits-init-is-out",
        [*SPLITS, "--init", "{dir}/model.npz", "--out", "{dir}/model.npz"],
        2,
        ("is the input --init",),
        INPUTS,
    ),
    Case(
        "splits-init-refused",
        [*SPLITS, "--init", "{dir}/model.npz", "--out", "{dir}/s.csv"],
        2,
        ("--init is not used by splits",),
        INPUTS,
        absent=("{dir}/s.csv",),
    ),
    Case(
        "train-extra-data-is-data",
        [*TRAIN, "--extra-data", "{dir}/./data.csv", "--out", "{dir}/m.npz"],
        2,
        ("--extra-data {dir}/./data.csv is the same file as DATA",),
        INPUTS,
        absent=("{dir}/m.npz",),
    ),
    Case(
        "train-extra-data-repeats-rows",
        [*TRAIN, "--extra-data", "{dir}/more.csv", "--out", "{dir}/m.npz"],
        2,
        ("--extra-data {dir}/more.csv: line 2 is the same sample as line 2 of DATA", "59 more rows"),
        absent=("{dir}/m.npz",),
        setup=scaled_tips("more.csv", n=60),
    ),
    Case(
        "transfer-real-four-motors",
        "transfer --method real-only --real {dir}/four.csv --robot three-cable --hidden 3 --out {dir}/m.npz".split(),
        2,
        ("--real {dir}/four.csv has 4 motor columns", "--robot three-cable has 3 motors"),
        absent=("{dir}/m.npz",),
        setup=four_motor_dataset,
    ),
    *(
        Case(
            f"transfer-real-cut-short-{how}",
            "transfer --method finetune-last --real {dir}/c.csv --sim-model {dir}/model.npz --out {dir}/o.npz".split(),
            2,
            ("{dir}/c.csv: line 61", words),
            ("{dir}/c.csv",),
            absent=("{dir}/o.npz",),
            setup=cut_short("c.csv", keep_fields=keep),
        )
        for how, keep, words in (("in-a-number", True, "does not end with a newline"), ("fields", False, "fields"))
    ),
    *(
        Case(
            f"transfer-{method}-sim-empty",
            f"transfer --method {method} --real {{dir}}/data.csv --sim {{dir}}/empty.csv --robot three-cable "
            "--out {dir}/m.npz".split(),
            2,
            ("--sim {dir}/empty.csv holds no samples",),
            absent=("{dir}/m.npz",),
            setup=scaled_tips("empty.csv", n=0),
        )
        for method in ("finetune", "calibrated")
    ),
    Case(
        "calibrate-noise-inf",
        ["calibrate", "{dir}/data.csv", "--noise-m", "inf", "--out", "{dir}/c.toml"],
        2,
        ("--noise-m must be finite and > 0, got inf",),
        absent=("{dir}/c.toml",),
    ),
    Case(
        "calibrate-tips-in-cm",
        ["calibrate", "{dir}/cm.csv", *COARSE, "--out", "{dir}/c.toml"],
        2,
        ("{dir}/cm.csv: column 'x'", "m from where the nominal FEM of three-cable puts it", "read as cm"),
        ("{dir}/cm.csv",),
        absent=("{dir}/c.toml",),
        setup=scaled_tips("cm.csv", scale=100.0),
    ),
    Case(
        "calibrate-tips-off-by-10-cm",
        ["calibrate", "{dir}/off.csv", *COARSE, "--out", "{dir}/c.toml"],
        1,
        ("misfits the tips of {dir}/off.csv by 0.1012 m RMS", "more than the 0.02 m"),
        absent=("{dir}/c.toml",),
        setup=scaled_tips("off.csv", shift_m=(0.0, 0.1, 0.0)),
    ),
    # --- calibrate --fit GROUPS (fit groups, density, tension tendons) ---------------------------------------------
    Case(
        "calibrate-fit-unknown-group",
        ["calibrate", "{dir}/data.csv", "--fit", "softness,stiffness", "--out", "{dir}/c.toml"],
        2,
        (
            "--fit must be a comma-separated subset of softness, gradient, eyelets, slack, density",
            "unknown fit group 'stiffness'",
        ),
        absent=("{dir}/c.toml",),
    ),  # fmt: skip
    Case(
        "calibrate-fit-slack-of-tension-tendons",
        ["calibrate", "--robot", "{dir}/tendons.toml", "{dir}/data.csv", "--fit", "slack", "--out", "{dir}/c.toml"],
        2,
        ("--fit slack: three-tendon has no angle-controlled cable",),
        absent=("{dir}/c.toml",),
        setup=lambda d: tendon_robot(d / "tendons.toml"),
    ),
    Case(
        "defects-huge-mesh",
        ["defects", "--random", "1", "--n-axial", "100000000", "--out", "{dir}/d.toml"],
        2,
        ("n_axial=100000000", "TB of memory"),
        absent=("{dir}/d.toml",),
    ),
    Case(
        "transfer-curve-jobs-zero",
        ["transfer-curve", "--sim-model", "{dir}/model.npz", "--jobs", "0", "--out", "{dir}/tc.csv"],
        2,
        ("--jobs must be a positive integer, got 0",),
        absent=("{dir}/tc.csv",),
    ),
    *(
        Case(
            f"transfer-curve-sim-model-{name}",
            ["transfer-curve", "--sim-model", f"{{dir}}/{name}.npz", "--family", "1", "--out", "{dir}/tc.csv"],
            2,
            (f"--sim-model {{dir}}/{name}.npz maps {n_u} motor angles", "--robot three-cable has 3 motors"),
            absent=("{dir}/tc.csv",),
            setup=setup,
        )
        for name, n_u, setup in (
            ("six", 6, lambda d: shutil.copy(ROOT / "data" / "model_sim_six_cable.npz", d / "six.npz")),
            ("four", 4, four_input_model),
        )
    ),
    Case(
        "transfer-curve-row-not-a-number",
        ["transfer-curve", "--sim-model", "{dir}/model.npz", "--family", "1", "--out", "{dir}/tc.csv"],
        2,
        ("{dir}/tc.csv: line 2: n_real 'five' is not a number",),
        ("{dir}/tc.csv", "{dir}/tc.csv.json"),
        setup=both(curve_file(), edit("tc.csv", "real-only,5,", "real-only,five,")),
    ),
    *(
        Case(
            f"transfer-curve-resumed-with-other-{name}",
            ["transfer-curve", "--sim-model", "{dir}/model.npz", "--family", "1", *flag, "--out", "{dir}/tc.csv"],
            2,
            ("{dir}/tc.csv was made with", words, "choose another --out"),
            ("{dir}/tc.csv", "{dir}/tc.csv.json"),
            setup=setup,
        )
        for name, flag, words, setup in (
            ("seed", ["--seed", "1"], "--seed 0 (this run: 1)", curve_file()),
            ("n-test", ["--n-test", "50"], "--n-test 100 (this run: 50)", curve_file()),
            ("sim-model", [], "--sim-model old.npz (this run: {dir}/model.npz)", curve_file(sim_model="old.npz")),
        )
    ),
    # --- simulate --commands, import-data --u-unit and --robot (datasets of several markers) ---
    *(
        Case(
            f"simulate-commands-{name}",
            [
                "simulate",
                "--commands",
                "{dir}/U.csv",
                *extra,
                "--jobs",
                "1",
                "--no-progress",
                *COARSE,
                "--out",
                "{dir}/o.csv",
            ],
            2,
            words,
            ("{dir}/U.csv",),
            absent=("{dir}/o.csv", "{dir}/o.csv.json", "{dir}/o.csv.chunks"),
            setup=write("U.csv", text) if text is not None else None,
        )
        for name, text, extra, words in (
            ("missing", None, [], ("--commands", "U.csv", "not found")),
            ("unknown-column", "u0,u1,u2,u7\n0,0,0,0\n", [], ("U.csv", "column 4 ('u7') names no input")),
            ("missing-column", "u0,lower-left\n0,0\n", [], ("U.csv", "no column for input(s) u2")),
            ("duplicate-column", "u0,u1,u2,top\n0,0,0,0\n", [], ("U.csv", "both give input u0")),
            ("nan", "u0,u1,u2\n0,0,0\n0,nan,0\n", [], ("U.csv", "line 3, column 'u1'", "NaN")),
            ("out-of-range", "u0,u1,u2\n0,0,9\n", [], ("U.csv", "line 2, column 'u2'", "outside")),
            ("with-grid", "u0,u1,u2\n0,0,0\n", ["--grid", "3"], ("--grid is not used with --commands",)),
            ("with-seed", "u0,u1,u2\n0,0,0\n", ["--seed", "1"], ("--seed is not used with --commands",)),
            ("empty", "u0,u1,u2\n", [], ("U.csv", "no data rows")),
        )
    ),
    *(
        Case(
            f"import-u-unit-{name}",
            ["import-data", "{dir}/t.csv", "--u", "a,b,c", "--y", "x,y,z", *extra, "--out", "{dir}/o.csv"],
            2,
            words,
            ("{dir}/t.csv",),
            absent=("{dir}/o.csv", "{dir}/o.csv.json"),
            setup=write("t.csv", text),
        )
        for name, text, extra, words in (
            (
                "negative-tension",
                "a,b,c,x,y,z\n1,-3,2,1,2,3\n",
                ["--u-unit", "N"],
                ("t.csv", "line 2, column 'b'", "not plausible for a tension"),
            ),
            (
                "huge-pressure",
                "a,b,c,x,y,z\n1,3,2000,1,2,3\n",
                ["--u-unit", "bar"],
                ("t.csv", "column 'c'", "not plausible for a pressure"),
            ),
            (
                "not-the-robots-kind",
                "a,b,c,x,y,z\n1,3,2,1,2,3\n",
                ["--u-unit", "N", "--robot", "{dir}/robot.toml"],
                ("--u-unit 'N' is a tension", "input u0", "an angle"),
            ),
            (
                "free-text-with-robot",
                "a,b,c,x,y,z\n1,3,2,1,2,3\n",
                ["--u-unit", "effort", "--robot", "three-cable"],
                ("--u-unit 'effort'", "rad"),
            ),
            ("list-too-short", "a,b,c,x,y,z\n1,3,2,1,2,3\n", ["--u-unit", "N,N"], ("--u-unit 'N,N'", "got 2")),
            (
                "unnamed-markers",
                "a,b,c,x,y,z,p,q,r\n1,3,2,1,2,3,4,5,6\n",
                ["--y", "x,y,z,p,q,r"],
                ("--y names 6 column(s)", "--markers"),
            ),
            (
                "markers-count",
                "a,b,c,x,y,z\n1,3,2,1,2,3\n",
                ["--markers", "ring"],
                ("--markers names 1 marker(s)", "0 triple(s)"),
            ),
        )
    ),
    # --- rows of the commands and flags of real robots' data, one module each ---------------
    *IMPORT_CASES,
    *BODY_CASES,
    *CHAMBER_CASES,
    *COMPARE_CASES,
    *INSPECT_CASES,
    *HISTORY_CASES,
    *REALTIME_CASES,
    *RIG_NONE_CASES,
    *UNITS_CASES,
    *EDITION_CASES,
    *DEFECTS_CASES,
    *DESCRIPTION_UNIT_CASES,
    *FOAM_CASES,
    *PNEUMATIC_CASES,
    *TIMES_CASES,
    *PROGRESS_CASES,
    *DESIGNS_CASES,
    *TRAINING_CASES,
    # --- markers the IK drives (track --markers) -------------------------------------------
    Case(
        "track-markers-unknown",
        [*TRACK, "--markers", "elbow", "--out", "{dir}/r.json"],
        2,
        ("['elbow'] not among the markers", "'tip'"),
        absent=("{dir}/r.json",),
    ),
    Case(
        "track-markers-repeated",
        [*TRACK, "--markers", "tip,tip", "--out", "{dir}/r.json"],
        2,
        ("markers must be distinct marker names",),
        absent=("{dir}/r.json",),
    ),
    Case(
        "track-markers-closed-loop",
        [*TRACK, "--closed-loop", "ilc", "--markers", "tip,mid", "--out", "{dir}/r.json"],
        2,
        ("--markers tip,mid", "drive markers other than the tip open loop"),
        absent=("{dir}/r.json",),
    ),
    # --- capture of a robot with markers -----------------------------------------------------
    Case(
        "capture-predictive-with-markers",
        [*CAPTURE, "--robot", "{dir}/robot.toml", "--protocol", "predictive", "--out", "{dir}/c.csv"],
        2,
        ("--protocol predictive watches the tip alone", "mid", "--protocol wait"),
        ("{dir}/robot.toml",),
        setup=edit(
            "robot.toml", "[tip_marker]", '[[markers]]\nname = "mid"\nposition_m = [0.1, 0.0, 0.0]\n\n[tip_marker]'
        ),
        absent=("{dir}/c.csv", "{dir}/c.journal.csv"),
    ),
]


@pytest.mark.parametrize("case", CASES, ids=str)
def test_sweep(case, tmp_path, capsys, monkeypatch):
    try:
        run_case(case, tmp_path, capsys, monkeypatch)
    finally:
        lock = _held.pop("lock", None)
        if lock is not None:
            lock.release()


def test_sweep_covers_every_command():
    from lab.cli import COMMANDS

    assert {c.argv[0] for c in CASES if c.module == "lab"} == set(COMMANDS)  # every command has rows


# --- mechanisms -------------------------------------------------------------------------------


def test_failed_run_does_not_poison_the_next(tmp_path, capsys, monkeypatch):
    from sweep import make_inputs

    from lab.cli import main

    make_inputs(tmp_path)
    robot = tmp_path / "robot.toml"
    good = robot.read_text()
    robot.write_text(good.replace("position_m = [0.20,", "position_m = [0.30,"))
    argv = [*SIM, "--robot", str(robot), "--out", str(tmp_path / "o.csv")]
    assert main(argv) == 2
    assert not (tmp_path / "o.csv.chunks").exists() and not (tmp_path / "o.csv.lock").exists()
    robot.write_text(good)
    assert main(argv) == 0 and (tmp_path / "o.csv").exists()


def test_restart_clears_only_the_checkpoint_files(tmp_path):
    from lab.data.chunkstore import ChunkStore, clear_checkpoint, remove_checkpoint

    fp = {"run": 1}
    store = ChunkStore(tmp_path / "ck", fp)
    assert not (tmp_path / "ck").exists()  # nothing is made before the first chunk
    store.save(0, {k: np.zeros(2) for k in ("order", "u_motor", "p_tip_W", "iterations", "factorizations", "time_s")})
    assert sorted(p.name for p in (tmp_path / "ck").iterdir()) == [
        ".lab-checkpoint",
        "chunk_00000.npz",
        "manifest.json",
    ]
    clear_checkpoint(tmp_path / "ck")
    assert [p.name for p in (tmp_path / "ck").iterdir()] == [".lab-checkpoint"]
    remove_checkpoint(tmp_path / "ck")
    assert not (tmp_path / "ck").exists()
    mine = tmp_path / "mine"
    mine.mkdir()
    ChunkStore(mine, fp).save(
        0, {k: np.zeros(2) for k in ("order", "u_motor", "p_tip_W", "iterations", "factorizations", "time_s")}
    )
    remove_checkpoint(mine)
    assert mine.is_dir() and not any(mine.iterdir())  # the user's directory stays, emptied of our files only


def test_write_dataset_leaves_the_old_pair_on_failure(tmp_path, monkeypatch):
    from lab.data import read_dataset, write_dataset

    u = np.arange(30.0).reshape(10, 3)
    write_dataset(tmp_path / "d.csv", u, u, {"v": 1})
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    real_replace = os.replace

    def fail_on_csv(src, dst):
        if str(dst).endswith(".csv"):
            raise OSError(28, "No space left on device", str(dst))
        real_replace(src, dst)

    monkeypatch.setattr(os, "replace", fail_on_csv)
    with pytest.raises(OSError):
        write_dataset(tmp_path / "d.csv", u[:5], u[:5], {"v": 2})
    monkeypatch.undo()
    # the sidecar was replaced before the CSV failed: the hash check refuses the mixed pair
    assert not [p for p in tmp_path.iterdir() if ".tmp" in p.name]
    with pytest.raises(ValueError, match="sidecar"):
        read_dataset(tmp_path / "d.csv")
    assert (tmp_path / "d.csv").read_bytes() == before["d.csv"]


def test_workers_exit_when_the_run_is_killed(tmp_path):
    import psutil

    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "lab",
            "simulate",
            "--grid",
            "9",
            "--chunk-size",
            "4",
            "--jobs",
            "2",
            "--no-progress",
            "--out",
            str(tmp_path / "o.csv"),
        ],
        cwd=tmp_path,
        env=subprocess_env(),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        parent = psutil.Process(proc.pid)

        def workers():
            return [p for p in parent.children(recursive=True) if "popen_loky" in " ".join(p.cmdline())]

        wait_until(lambda: len(workers()) == 2, 60, "two loky workers")
        wait_until(lambda: (tmp_path / "o.csv.chunks").exists(), 60, "the first chunk")
        pids = [w.pid for w in workers()]
        proc.kill()  # kill -9: no handler runs
        proc.wait()
        t0 = time.monotonic()
        wait_until(
            lambda: not any(psutil.pid_exists(p) and psutil.Process(p).status() != "zombie" for p in pids),
            10,
            "the workers to exit",
        )
        assert time.monotonic() - t0 < 10
    finally:
        if proc.poll() is None:
            proc.kill()
        for p in psutil.process_iter(["cmdline"]):
            if "popen_loky" in " ".join(p.info["cmdline"] or []) and str(proc.pid) in " ".join(p.info["cmdline"] or []):
                p.kill()


@pytest.mark.parametrize("sig, code", [(signal.SIGTERM, 143), (signal.SIGHUP, 129)])
def test_capture_stops_cleanly_on_sigterm_and_sighup(sig, code, tmp_path):
    journal = tmp_path / "c.journal.csv"
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "lab",
            "capture",
            "--rig",
            "twin",
            "--grid",
            "4",
            "--no-progress",
            "--out",
            str(tmp_path / "c.csv"),
        ],
        cwd=tmp_path,
        env=subprocess_env(),
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        wait_until(
            lambda: journal.exists() and len(journal.read_text().splitlines()) >= 4, 120, "samples in the journal"
        )
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == code, err
    assert "rig was closed" in err and str(journal) in err and "Traceback" not in err
    assert not (tmp_path / "c.csv").exists()
    rows = [ln for ln in journal.read_text().splitlines() if ln[:1].isdigit()]
    assert rows and all(len(r.split(",")) == len(rows[0].split(",")) for r in rows)  # nothing torn


def test_track_keeps_measured_points_when_the_rig_fails(tmp_path, monkeypatch, capsys):
    from sweep import make_inputs

    from lab.capture.protocol import measure as real_measure
    from lab.cli import main
    from lab.rig import RigError

    make_inputs(tmp_path)
    calls = []

    def measure(rig, u, protocol):
        calls.append(1)
        if len(calls) == 3:
            raise RigError("servo 2 stopped answering")
        return real_measure(rig, u, protocol)

    monkeypatch.setattr("lab.tracking.track.measure", measure)
    out = tmp_path / "r.json"
    assert main([*[a.replace("{dir}", str(tmp_path)) for a in TRACK], "--out", str(out)]) == 1
    err = capsys.readouterr().err
    points = tmp_path / "r.json.points.csv"
    assert "2 points measured so far" in err and str(points) in err and not out.exists()
    lines = points.read_text().splitlines()
    assert lines[0].startswith("i,target_x") and len(lines) == 3
