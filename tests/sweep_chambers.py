"""Fault-sweep rows (tests/sweep.py format) for fluid chambers and the Yeoh material.

Each row edits the case's copy of the pneumatic arm (``arm.toml``, lab/robots) and runs
``simulate`` on it: a chamber that leaves the body or overlaps another, a wall thinner than
one element, a pressure or volume bound implausible for its unit, a negative pressure where
the design forbids it, a volume range that would collapse the cavity, NaN, a field the mode
does not use, a bad Yeoh coefficient: exit 2 naming the field and the file, before anything
is written. Rows that reach the command check the inputs it is given.
"""

from sweep import COARSE, ROOT, Case

SIM = ["simulate", "--grid", "2", "--jobs", "1", "--no-progress"]
ARM = [*SIM, "--robot", "{dir}/arm.toml", "--out", "{dir}/o.csv"]
TOP = """name = "top"
angle_deg = 90.0
offset_m = 0.0095
radius_m = 0.0045
start_m = 0.01
end_m = 0.19
pressure_max_pa = 200e3"""


def arm(old=None, new=None):
    """A setup writing the pneumatic arm with ``old`` replaced by ``new`` (once)."""

    def setup(d):
        text = (ROOT / "lab" / "robots" / "pneumatic-arm.toml").read_text()
        if old is not None:
            assert old in text, f"pneumatic-arm.toml has no {old!r}"
            text = text.replace(old, new, 1)
        (d / "arm.toml").write_text(text)

    return setup


def top(old, new):
    """The first chamber with ``old`` replaced by ``new``."""
    return arm(TOP, TOP.replace(old, new, 1))


def _no_chambers(d):
    """The arm with ``chambers = []`` instead of its three ``[[chambers]]``."""
    text = (ROOT / "lab" / "robots" / "pneumatic-arm.toml").read_text()
    head, _, rest = text.partition("[[chambers]]")
    tail = rest[rest.index("[tip_marker]") :]
    (d / "arm.toml").write_text(head.replace("format_version = 1", "format_version = 1\nchambers = []") + tail)


def case(name, words, setup, argv=ARM):
    """A row refused with exit 2 whose output never appears."""
    return Case(name, argv, 2, words, setup=setup, absent=("{dir}/o.csv",))


CHAMBER_CASES = [
    case(
        "chamber-leaves-the-body",
        ("chambers[0] ('top')", "leaves the body", "arm.toml"),
        top("offset_m = 0.0095", "offset_m = 0.018"),
    ),
    case(
        "chamber-wall-thinner-than-an-element",
        ("chambers[0] ('top')", "thinner than one element"),
        top("radius_m = 0.0045", "radius_m = 0.0062"),
    ),
    case(
        "chamber-overlaps-another",
        ("chambers[1] ('lower-left') overlaps chambers[0] ('top')",),
        top("angle_deg = 90.0", "angle_deg = 200.0"),
    ),
    case(
        "chamber-wall-between-too-thin",
        ("the wall between them is thinner than one element",),
        top("angle_deg = 90.0", "angle_deg = 140.0"),
    ),
    case("chamber-open-at-the-base", ("must stay one element", "base"), top("start_m = 0.01", "start_m = 0.002")),
    case("chamber-beyond-the-tip", ("must stay one element",), top("end_m = 0.19", "end_m = 0.21")),
    case("chamber-end-before-start", ("chambers[0].end_m",), top("end_m = 0.19", "end_m = 0.005")),
    case(
        "chamber-pressure-in-kpa",
        ("chambers[0].pressure_max_pa", "implausible", "pascals"),
        top("pressure_max_pa = 200e3", "pressure_max_pa = 60"),
    ),
    case(
        "chamber-pressure-nan",
        ("chambers[0].pressure_max_pa", "finite"),
        top("pressure_max_pa = 200e3", "pressure_max_pa = nan"),
    ),
    case(
        "chamber-pressure-below-vacuum",
        ("chambers[0].pressure_min_pa", "vacuum"),
        top("pressure_max_pa = 200e3", "pressure_max_pa = 200e3\npressure_min_pa = -2e5"),
    ),
    case(
        "chamber-volume-field-on-pressure",
        ("chambers[0].volume_max_m3", 'not used by control = "pressure"'),
        top("pressure_max_pa = 200e3", "pressure_max_pa = 200e3\nvolume_max_m3 = 1e-6"),
    ),
    case("chamber-unknown-control", ("chambers[0].control",), top('name = "top"', 'name = "top"\ncontrol = "flow"')),
    case(
        "chamber-volume-in-ml",
        ("chambers[0].volume_max_m3", "implausible"),
        top("pressure_max_pa = 200e3", 'control = "volume"\nvolume_max_m3 = 5.0'),
    ),
    case(
        "chamber-volume-collapses",
        ("chambers[0].volume_min_m3", "collapse"),
        top("pressure_max_pa = 200e3", 'control = "volume"\nvolume_max_m3 = 2e-6\nvolume_min_m3 = -2e-5'),
    ),
    case(
        "chamber-volume-pressure-field",
        ("chambers[0].pressure_max_pa", 'not used by control = "volume"'),
        top("name", 'control = "volume"\nvolume_max_m3 = 2e-6\nname'),
    ),
    case(
        "chamber-bulk-modulus-implausible",
        ("chambers[0].fluid_bulk_modulus_pa", "implausible"),
        top("pressure_max_pa = 200e3", 'control = "volume"\nvolume_max_m3 = 2e-6\nfluid_bulk_modulus_pa = 10.0'),
    ),
    case(
        "chamber-surface-group-on-a-cylinder",
        ("chambers[0].surface_group", "not used"),
        top('name = "top"', 'name = "top"\nsurface_group = "cavity"'),
    ),
    case("chamber-misspelt-field", ("chambers[0]", "did you mean 'radius_m'"), top("radius_m", "radius_mm")),
    case("chamber-name-taken", ("must be unique",), top('name = "top"', 'name = "lower-left"')),
    case("chambered-mesh-needs-size", ("mesh.size_m",), arm("size_m = 0.005", "n_rings = 3\nn_axial = 20")),
    case(
        "chambered-resolution-flag-refused",
        ("--n-rings is not used by robot 'pneumatic-arm'", "mesh.size_m"),
        arm(),
        [*ARM, *COARSE],
    ),
    case(
        "chambers-empty-list",
        ("field 'chambers' must be a non-empty list",),
        _no_chambers,
    ),
    case(
        "material-yeoh-c10-in-mpa",
        ("material.yeoh_c10_pa", "implausible"),
        arm("yeoh_c10_pa = 110e3", "yeoh_c10_pa = 0.11"),
    ),
    case(
        "material-yeoh-with-youngs-modulus",
        ("material.youngs_modulus_pa", 'not used by model = "yeoh"'),
        arm("yeoh_c10_pa = 110e3", "yeoh_c10_pa = 110e3\nyoungs_modulus_pa = 6e5"),
    ),
    case(
        "material-yeoh-both-nu-and-bulk",
        ("exactly one of 'material.poisson_ratio' and 'material.bulk_modulus_pa'",),
        arm("poisson_ratio = 0.45", "poisson_ratio = 0.45\nbulk_modulus_pa = 1e7"),
    ),
    case(
        "material-yeoh-bulk-below-shear",
        ("material.bulk_modulus_pa", "below the shear modulus"),
        arm("poisson_ratio = 0.45", "bulk_modulus_pa = 1e4"),
    ),
    case(
        "material-yeoh-nu-half",
        ("material.poisson_ratio", "[0, 0.5)"),
        arm("poisson_ratio = 0.45", "poisson_ratio = 0.5"),
    ),
    case(
        "material-yeoh-field-on-neo-hookean",
        ("material.yeoh_c20_pa", 'not used by model = "neo-hookean"'),
        arm('model = "yeoh"\nyeoh_c10_pa = 110e3', 'model = "neo-hookean"\nyoungs_modulus_pa = 6e5'),
    ),
    case(
        "material-unknown-model",
        ('field \'material.model\' must be "neo-hookean" or "yeoh"',),
        arm('model = "yeoh"', 'model = "mooney"'),
    ),
]
