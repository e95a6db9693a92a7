"""Fault-sweep rows (tests/sweep.py format): a robot description whose motor range is in the
wrong unit (degrees where radians belong) is refused by every command that reads it --
``capture`` and ``simulate`` here -- naming the field and the unit that fits."""

from pathlib import Path

from sweep import Case


def _u_max(value: str):
    def setup(d: Path):
        p = d / "robot.toml"
        text = p.read_text()
        old = next(line for line in text.splitlines() if line.startswith("u_max_rad"))
        p.write_text(text.replace(old, f"u_max_rad = {value}", 1))

    return setup


DESCRIPTION_UNIT_CASES = [
    Case(
        "capture-u-max-in-degrees",
        [
            "capture",
            "--rig",
            "twin",
            "--robot",
            "{dir}/robot.toml",
            "--grid",
            "2",
            "--no-progress",
            "--out",
            "{dir}/c.csv",
        ],
        2,
        ("actuation.u_max_rad", "ten turns", "in degrees", "3.142 rad"),
        unchanged=("{dir}/robot.toml",),
        absent=("{dir}/c.csv",),
        setup=_u_max("180.0"),
    ),  # fmt: skip
    Case(
        "simulate-u-max-in-degrees",
        ["simulate", "--robot", "{dir}/robot.toml", "--grid", "2", "--no-progress", "--out", "{dir}/s.csv"],
        2,
        ("actuation.u_max_rad", "in degrees"),
        unchanged=("{dir}/robot.toml",),
        absent=("{dir}/s.csv",),
        setup=_u_max("150.0"),
    ),  # fmt: skip
]
