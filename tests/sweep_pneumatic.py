"""Fault-sweep rows (tests/sweep.py format) for the pneumatic family: ``python -m lab defects
--pneumatic SEED``, ``--rig twin:pneumatic:SEED`` and a pneumatic member's defects file read
back by ``--rig twin:FILE``. A bad seed, a robot without chambers (or ``--random``/``--foam``
on one with them), a mesh flag, two families at once, and a ``[[chambers]]`` field that is
implausible, misspelt or given to a cable robot all end with exit 2 naming the problem
before anything is written; a huge seed is a robot like any other.
"""

import tomllib

from sweep import Case

from lab.asbuilt import PNEUMATIC
from lab.description import load_robot

DEFECTS = ["defects", "--out", "{dir}/d.toml"]
NO_D = ("{dir}/d.toml",)
CAPTURE = ["capture", "--grid", "2", "--no-progress", "--out", "{dir}/c.csv"]
NO_C = ("{dir}/c.csv", "{dir}/c.journal.csv")
PNEU = ["--robot", "pneumatic-arm"]
HUGE = "123456789012345678901234567890"


def member(old: str | None = None, new: str | None = None):
    """A setup writing member 0's defects file as ``{dir}/p.toml``, its first ``old`` replaced by ``new``."""

    def setup(d):
        text = PNEUMATIC.toml(load_robot("pneumatic-arm"), 0)
        if old is not None:
            assert old in text, old
            text = text.replace(old, new, 1)
        (d / "p.toml").write_text(text)

    return setup


def _pneumatic_file(d):
    data = tomllib.loads((d / "d.toml").read_text())
    assert len(data["chambers"]) == 3 and "cables" not in data and "motors" not in data, data


def bad_file(case_id: str, setup, *words: str) -> Case:
    argv = [*CAPTURE, *PNEU, "--rig", "twin:{dir}/p.toml"]
    return Case(case_id, argv, 2, ("p.toml", *words), ("{dir}/p.toml",), NO_C, setup=setup)


PNEUMATIC_CASES: list = [
    Case(
        "pneumatic-defects-cable-robot",
        [*DEFECTS, "--pneumatic", "1", "--robot", "three-cable"],
        2,
        ("robot 'three-cable' has no pressure chambers", "twin:random:SEED"),
        absent=NO_D,
    ),
    Case("pneumatic-defects-default-robot", [*DEFECTS, "--pneumatic", "2"], 0, ("pneumatic-arm as built", "member 2")),
    Case("pneumatic-defects-negative", [*DEFECTS, *PNEU, "--pneumatic", "-3"], 2, ("--pneumatic", ">= 0"), absent=NO_D),
    Case(
        "pneumatic-defects-not-a-number",
        [*DEFECTS, *PNEU, "--pneumatic", "x"],
        2,
        ("--pneumatic", "invalid int value: 'x'"),
        absent=NO_D,
        subprocess=True,
    ),
    Case(
        "pneumatic-defects-with-random",
        [*DEFECTS, *PNEU, "--random", "1", "--pneumatic", "2"],
        2,
        ("--random and --pneumatic", "give one"),
        absent=NO_D,
    ),
    Case("pneumatic-defects-neither", [*DEFECTS, *PNEU], 2, ("--random SEED", "--pneumatic SEED"), absent=NO_D),
    *(
        Case(
            f"pneumatic-defects-{flag.strip('-')}-on-pneumatic-arm",
            [*DEFECTS, *PNEU, flag, "1"],
            2,
            ("driven by pressure chambers", "twin:pneumatic:SEED"),
            absent=NO_D,
        )
        for flag in ("--random", "--foam")
    ),
    Case(
        "pneumatic-defects-mesh-flag",
        [*DEFECTS, *PNEU, "--pneumatic", "1", "--n-rings", "2"],
        2,
        ("meshed by gmsh",),
        absent=NO_D,
    ),
    Case("pneumatic-defects-huge-seed", [*DEFECTS, *PNEU, "--pneumatic", HUGE], 0, after=_pneumatic_file),
    *(
        Case(
            f"pneumatic-capture-rig-{spec.replace(':', '-')}",
            [*CAPTURE, *PNEU, "--rig", spec],
            2,
            (f"rig '{spec}'", "twin:pneumatic:SEED"),
            absent=NO_C,
        )
        for spec in ("twin:pneumatic:x", "twin:pneumatic", "twin:pneumatic:-1")
    ),
    Case(
        "pneumatic-capture-rig-on-cable-robot",
        [*CAPTURE, "--rig", "twin:pneumatic:1"],
        2,
        ("robot 'three-cable' has no pressure chambers",),
        absent=NO_C,
    ),
    bad_file(
        "pneumatic-file-offset-implausible",
        member("regulator_offset_pa = -164.0", "regulator_offset_pa = 1e6"),
        "'chambers[0].regulator_offset_pa'",
        "[-20000, 20000] Pa",
    ),
    bad_file(
        "pneumatic-file-tau-zero",
        member("regulator_tau_s = 0.044", "regulator_tau_s = 0.0"),
        "'chambers[1].regulator_tau_s'",
        "[0.001, 10] s",
    ),
    bad_file(
        "pneumatic-file-cavity-out-of-body",
        member("offset_error_m = 0.000312", "offset_error_m = 0.004"),
        "offset_error_m",
        "thinner than one element",
    ),
    bad_file(
        "pneumatic-file-misspelt",
        member("stiffness = 1.123", "stifness = 1.123"),
        "chambers[0]",
        "'stifness'",
    ),
    bad_file("pneumatic-file-chamber-missing", member('name = "lower-right"', 'name = "lower-rite"'), "'lower-right'"),
    Case(
        "pneumatic-file-on-cable-robot",
        [*CAPTURE, "--rig", "twin:{dir}/p.toml"],
        2,
        ("p.toml", "'pneumatic-arm'", "'three-cable'"),
        ("{dir}/p.toml",),
        NO_C,
        setup=member(),
    ),
]
