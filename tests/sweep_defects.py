"""Fault-sweep rows (tests/sweep.py format) for the optional defects-file fields: base tilt,
the mocap's frame error, cable stiffness, creep and the material law. Each bad value in the
case's copy of the shipped ``defects.toml``, read by ``capture --rig twin:FILE`` (and once by
``track``), must end with exit 2 naming the file, the field and its allowed range, before
anything is written.
"""

from pathlib import Path

from sweep import Case

CAPTURE = ["capture", "--rig", "twin:{dir}/defects.toml", "--grid", "2", "--no-progress", "--out", "{dir}/c.csv"]
TRACK = ["track", "--model", "{dir}/model.npz", "--trajectory", "{dir}/traj.csv"]
DEFECTS = ("{dir}/defects.toml",)
NO_OUT = ("{dir}/c.csv", "{dir}/c.csv.chunks")
TILT, RANGE = "'mount.tilt_deg'", "[-30, 30] deg"
ALPHA = "'material.hyperfoam_alpha'"


def after(old: str, new: str):
    """A setup that replaces the first ``old`` in the case's ``defects.toml`` by ``new``
    (``old`` is kept when ``new`` contains it; ``old = None``: appends ``new``)."""

    def setup(d: Path):
        p = d / "defects.toml"
        text = p.read_text()
        if old is None:
            p.write_text(text + new)
            return
        assert old in text, f"defects.toml has no {old!r}"
        p.write_text(text.replace(old, new, 1))

    return setup


def mount(tilt: str, axis: str = "[0.0, 1.0, 0.0]"):
    """A setup appending ``[mount]`` with these ``tilt_deg`` and ``tilt_axis`` texts."""
    return after(None, f"\n[mount]\ntilt_deg = {tilt}\ntilt_axis = {axis}\n")


def hyperfoam(alpha: str):
    """A setup choosing the hyperfoam law with this ``hyperfoam_alpha`` text."""
    law = 'law = "hyperfoam"\nhyperfoam_mu_pa = 13000.0\nhyperfoam_beta = 0.1'
    return after("softness = 0.75", f"softness = 0.75\n{law}\nhyperfoam_alpha = {alpha}")


def mocap(lines: str):
    """A setup adding ``lines`` to ``[mocap]``."""
    return after("frame_rate_hz = 120.0", f"frame_rate_hz = 120.0\n{lines}")


def bad(case_id: str, setup, *words: str, argv=CAPTURE) -> Case:
    return Case(case_id, argv, 2, ("defects.toml", *words), DEFECTS, NO_OUT, setup=setup)


DEFECTS_CASES: list = [
    bad("defects-tilt-nan", mount("nan"), TILT, RANGE, "got nan"),
    bad("defects-tilt-huge", mount("90.0"), TILT, RANGE, "got 90.0"),
    bad("defects-tilt-axis-zero", mount("5.0", "[0.0, 0.0, 0.0]"), "'mount.tilt_axis'", "nonzero length"),
    bad("defects-tilt-no-axis", after(None, "\n[mount]\ntilt_deg = 5.0\n"), "missing field 'mount.tilt_axis'"),
    bad(
        "defects-mount-misspelt",
        after(None, "\n[mount]\ntilt_degrees = 5.0\n"),
        "[mount] has no field 'tilt_degrees'",
        "did you mean 'tilt_deg'?",
    ),
    bad(
        "defects-frame-rotation-huge",
        mocap("frame_rotation_deg = -45.0\nframe_rotation_axis = [0.0, 0.0, 1.0]"),
        "'mocap.frame_rotation_deg'",
        "[-10, 10] deg",
    ),
    bad(
        "defects-frame-axis-missing",
        mocap("frame_rotation_deg = 1.0"),
        "missing field 'mocap.frame_rotation_axis'",
    ),
    bad(
        "defects-frame-offset-huge",
        mocap("frame_offset_m = [0.0, 0.0, 1e6]"),
        "'mocap.frame_offset_m'",
        "<= 0.1 m",
    ),
    bad(
        "defects-cable-stiffness-negative",
        after("play_m = 0.0001", "play_m = 0.0001\nstiffness_n_per_m = -300.0"),
        "'cables[0].stiffness_n_per_m'",
        "[10, 1e+12] N/m",
    ),
    bad(
        "defects-cable-stiffness-string",
        after("slack_m = 0.003 ", 'stiffness_n_per_m = "stiff"\nslack_m = 0.003 '),
        "'cables[1].stiffness_n_per_m'",
        "'stiff'",
    ),
    bad(
        "defects-creep-fraction-one",
        after("slow_fraction = 0.3", "slow_fraction = 0.3\ncreep_fraction = 1.0\ncreep_tau_s = 300.0"),
        "'lag.creep_fraction'",
        "[0, 1)",
    ),
    bad(
        "defects-creep-too-large-with-slow",
        after("slow_fraction = 0.3", "slow_fraction = 0.3\ncreep_fraction = 0.75\ncreep_tau_s = 300.0"),
        "'lag.creep_fraction'",
        "must be < 1",
    ),
    bad(
        "defects-creep-tau-below-slow",
        after("slow_fraction = 0.3", "slow_fraction = 0.3\ncreep_fraction = 0.1\ncreep_tau_s = 0.5"),
        "'lag.creep_tau_s'",
        "[2.5, 86400] s",
    ),
    bad(
        "defects-creep-tau-missing",
        after("slow_fraction = 0.3", "slow_fraction = 0.3\ncreep_fraction = 0.1"),
        "missing field 'lag.creep_tau_s'",
    ),
    bad("defects-law-unknown", after("softness = 0.75", 'softness = 0.75\nlaw = "ogden"'), "'material.law'", "'ogden'"),
    bad(
        "defects-hyperfoam-params-missing",
        after("softness = 0.75", 'softness = 0.75\nlaw = "hyperfoam"'),
        "missing field 'material.hyperfoam_mu_pa'",
    ),
    bad("defects-hyperfoam-alpha-zero", hyperfoam("0.0"), ALPHA, "nonzero"),
    bad("defects-hyperfoam-alpha-nan", hyperfoam("nan"), ALPHA, "[-50, 50]"),
    bad(
        "defects-hyperfoam-params-without-law",
        after("softness = 0.75", "softness = 0.75\nhyperfoam_beta = 0.1"),
        "'material.hyperfoam_beta'",
        'only with law = "hyperfoam"',
    ),
    Case(
        "defects-track-tilt-nan",
        [*TRACK, "--rig", "twin:{dir}/defects.toml", "--out", "{dir}/r.json"],
        2,
        ("defects.toml", TILT, RANGE),
        DEFECTS,
        ("{dir}/r.json",),
        setup=mount("nan"),
    ),
]
