"""Fault-sweep rows (tests/sweep.py format) for the foam family: ``--rig twin:foam:SEED``
wherever a rig is taken, and ``python -m lab defects --foam SEED``. A bad seed ends with
exit 2 naming the rig and its form before anything is written; ``--foam`` with ``--random``
(two families) or neither is refused; a huge seed is a robot like any other.
``transfer-curve --family-kind`` takes random or foam only, and a file of one family is not
resumed with the other (a file made before the flag is of the random family).
"""

import json
import tomllib

from sweep import Case

from lab.asbuilt.arm import load_defects
from lab.description import ROBOTS_DIR, load_robot

CAPTURE = ["capture", "--grid", "2", "--no-progress", "--out", "{dir}/c.csv"]
NOT_CAPTURED = ("{dir}/c.csv", "{dir}/c.journal.csv")
TRACK = ["track", "--model", "{dir}/model.npz", "--trajectory", "{dir}/traj.csv", "--out", "{dir}/r.json"]
DEFECTS = ["defects", "--out", "{dir}/d.toml"]
HUGE = "123456789012345678901234567890"
CURVE = ["transfer-curve", "--sim-model", "{dir}/model.npz", "--family", "1", "--out", "{dir}/tc.csv"]


def _copy_six(d):
    (d / "six.toml").write_bytes((ROBOTS_DIR / "six-cable.toml").read_bytes())


def _random_curve(recorded: bool):
    """A setup writing ``tc.csv``: one random-family transfer-curve row; its sidecar records
    ``family_kind`` if ``recorded`` (else it is a file from before the setting)."""

    def setup(d):
        from lab.studies.transfer_curve import COLUMNS, TransferCurveSpec

        spec = TransferCurveSpec(sim_model=str(d / "model.npz"))
        row = {c: "0.01" for c in COLUMNS} | {"robot": "random:0", "method": "real-only", "n_real": "5"}
        (d / "tc.csv").write_text(",".join(COLUMNS) + "\n" + ",".join(row[c] for c in COLUMNS) + "\n")
        meta = {"kind": "lab.transfer_curve", "robot": spec.robot, "sim_model": spec.sim_model, **spec.settings()}
        if not recorded:
            del meta["family_kind"]
        (d / "tc.csv.json").write_text(json.dumps(meta))

    return setup


def _foam_file(d):
    data = tomllib.loads((d / "d.toml").read_text())
    assert data["material"]["law"] == "hyperfoam" and "mount" in data, data
    return data


FOAM_CASES: list = [
    *(
        Case(
            f"foam-capture-rig-{spec.replace(':', '-')}",
            [*CAPTURE, "--rig", spec],
            2,
            (f"rig '{spec}'", "twin:foam:SEED"),
            absent=NOT_CAPTURED,
        )
        for spec in ("twin:foam:x", "twin:foam", "twin:foam:-1", "twin:foam:2.5")
    ),
    Case(
        "foam-track-rig-bad-seed",
        [*TRACK, "--rig", "twin:foam:abc"],
        2,
        ("rig 'twin:foam:abc'", "non-negative integer"),
        ("{dir}/model.npz", "{dir}/traj.csv"),
        ("{dir}/r.json",),
    ),
    Case(
        "foam-fit-dynamics-rig-bad-seed",
        ["fit-dynamics", "--rig", "twin:foam:", "--out", "{dir}/dyn.npz"],
        2,
        ("needs the robot's seed: --rig twin:foam:SEED",),
        absent=("{dir}/dyn.npz",),
    ),
    Case(
        "foam-defects-with-random",
        [*DEFECTS, "--random", "1", "--foam", "2"],
        2,
        ("--random and --foam", "give one"),
        absent=("{dir}/d.toml",),
    ),
    Case(
        "foam-defects-neither-family",
        DEFECTS,
        2,
        ("--random SEED", "--foam SEED"),
        absent=("{dir}/d.toml",),
    ),
    Case("foam-defects-negative", [*DEFECTS, "--foam", "-3"], 2, ("--foam", ">= 0"), absent=("{dir}/d.toml",)),
    Case(
        "foam-defects-not-a-number",
        [*DEFECTS, "--foam", "x"],
        2,
        ("--foam", "invalid int value: 'x'"),
        absent=("{dir}/d.toml",),
        subprocess=True,
    ),
    Case(
        "foam-defects-huge-mesh",
        [*DEFECTS, "--foam", "1", "--n-axial", "100000000"],
        2,
        ("n_axial=100000000", "TB of memory"),
        absent=("{dir}/d.toml",),
    ),
    Case(
        "foam-defects-out-is-robot",
        ["defects", "--foam", "1", "--robot", "{dir}/robot.toml", "--out", "{dir}/robot.toml"],
        2,
        ("is the input --robot", "refusing"),
        unchanged=("{dir}/robot.toml",),
    ),
    Case("foam-defects-huge-seed", [*DEFECTS, "--foam", HUGE], 0, after=_foam_file),
    Case(
        "foam-defects-six-cable-by-path",
        [*DEFECTS, "--foam", "2", "--robot", "{dir}/six.toml"],
        0,
        setup=_copy_six,
        unchanged=("{dir}/six.toml",),
        after=lambda d: load_defects(d / "d.toml", load_robot(d / "six.toml")),
    ),
    Case(
        "foam-transfer-curve-family-kind-bogus",
        [*CURVE, "--family-kind", "bogus"],
        2,
        ("--family-kind", "invalid choice: 'bogus'"),
        absent=("{dir}/tc.csv",),
        subprocess=True,
    ),
    *(
        Case(
            f"foam-transfer-curve-resumes-random-{name}",
            [*CURVE, "--family-kind", "foam"],
            2,
            ("{dir}/tc.csv was made with", "--family-kind random (this run: foam)", "choose another --out"),
            ("{dir}/tc.csv", "{dir}/tc.csv.json"),
            setup=_random_curve(recorded),
        )
        for name, recorded in (("file", True), ("file-from-before-the-flag", False))
    ),
]
