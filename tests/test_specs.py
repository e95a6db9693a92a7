"""The typed-settings mechanism: option() declarations carry the help, type, unit and check; a
spec validates itself naming the field ``Class.field``; the command line builds its flags from
the declarations and the fields' types, turns parsed arguments back into the spec, and names
a field's flag in an error (lab.specs, lab.cli.flags)."""

from __future__ import annotations

import argparse
import math
from dataclasses import FrozenInstanceError, dataclass

import pytest

from lab.cli import main
from lab.cli.flags import add_spec_flags, flag_name, given, refuse_unused, spec_from_args
from lab.control import IKConfig
from lab.errors import FieldError, InputError
from lab.fem import MeshSpec
from lab.specs import Spec, at_most, non_negative, option, positive, positive_int
from lab.tracking.stream_spec import StreamSpec


@dataclass(frozen=True)
class Demo(Spec):
    rate_hz: float = option(10.0, help="sampling rate", unit="Hz", check=at_most(200.0, positive, " Hz"))
    count: int = option(3, help="how many", check=positive_int)
    method: str = option("lm", help="the solver", choices=("lm", "gd"))
    widths: tuple[int, ...] = option((20, 20), help="hidden widths")
    weight: float | None = option(None, help="a weight", check=non_negative)
    quiet: bool = option(False, help="say nothing")
    internal: int = option(0, help="not a flag", cli=False)


def test_a_spec_refuses_bad_values_naming_the_field():
    with pytest.raises(FieldError, match=r"^Demo.rate_hz must be finite and > 0, got nan Hz$") as err:
        Demo(rate_hz=math.nan)
    assert (err.value.spec, err.value.field, err.value.fields) == ("Demo", "rate_hz", ("rate_hz",))
    with pytest.raises(InputError, match=r"Demo.rate_hz must be at most 200 Hz, got 1000000000.0 Hz"):
        Demo(rate_hz=1e9)
    with pytest.raises(InputError, match=r"^Demo.count must be a positive integer, got 0$"):
        Demo(count=0)
    with pytest.raises(InputError, match=r"Demo.count must be a positive integer, got True"):
        Demo(count=True)  # a bool is not a count
    with pytest.raises(InputError, match=r"Demo.method must be one of lm, gd, got 'bfgs'"):
        Demo(method="bfgs")
    with pytest.raises(InputError, match=r"Demo.weight must be finite and >= 0, got -1"):
        Demo(weight=-1.0)
    assert Demo(weight=None).weight is None  # None means "not set": no check
    with pytest.raises(FrozenInstanceError):
        Demo().count = 4
    with pytest.raises(InputError, match="Demo.count"):
        Demo().replace(count=-2)  # a copy is validated again


def test_a_rule_over_several_fields_names_them_all_and_the_cli_writes_the_flags():
    err = Demo.field_error(
        "Demo.count goes with Demo.weight and MeshSpec.n_rings", "count", "weight", "MeshSpec.n_rings"
    )
    assert err.names == ("Demo.count", "Demo.weight", "MeshSpec.n_rings") and err.fields == (
        "count",
        "weight",
        "n_rings",
    )
    flags = {"Demo.count": "--count", "Demo.weight": "--weight"}
    assert err.renamed(lambda name: flags.get(name, name)) == "--count goes with --weight and MeshSpec.n_rings"
    parser = argparse.ArgumentParser()
    add_spec_flags(parser, Demo)
    assert flag_name("Demo.count") == "--count" and flag_name("Demo.internal") == "Demo.internal"
    assert err.renamed(flag_name).startswith("--count goes with --weight and ")


def test_the_command_line_names_the_flag_the_user_typed(capsys):
    """A spec built in Python names ``IKConfig.method``; from ``track --solver`` the flag."""
    with pytest.raises(FieldError, match=r"^IKConfig.method must be one of lm, gd, dfo, got 'bfgs'$"):
        IKConfig(method="bfgs")
    with pytest.raises(FieldError, match=r"^StreamSpec.period_s must lie in \[0.5, 600\] s, got -1.0 s$"):
        StreamSpec(period_s=-1.0)
    args = ["track", "--soft-ik", "--trajectory", "circle", "--rig", "sim", "--period-s", "-1", "--out", "x.json"]
    assert main(args) == 2
    assert capsys.readouterr().err.strip() == "error: --period-s must lie in [0.5, 600] s, got -1.0 s"


def test_flags_come_from_the_declarations_and_round_trip():
    parser = argparse.ArgumentParser()
    add_spec_flags(parser, Demo)
    flags = {o for a in parser._actions for o in a.option_strings}
    assert {
        "--rate-hz",
        "--count",
        "--method",
        "--widths",
        "--weight",
        "--quiet",
    } <= flags and "--internal" not in flags
    helps = {a.dest: a.help for a in parser._actions}
    assert helps["rate_hz"] == "sampling rate (default: 10.0)" and helps["widths"] == "hidden widths (default: 20 20)"
    assert spec_from_args(Demo, parser.parse_args([])) == Demo()  # unset flags: the spec's defaults
    args = parser.parse_args(["--rate-hz", "50", "--method", "gd", "--widths", "8", "4", "--quiet"])
    assert spec_from_args(Demo, args) == Demo(rate_hz=50.0, method="gd", widths=(8, 4), quiet=True)
    with pytest.raises(FieldError, match="Demo.count") as err:
        spec_from_args(Demo, parser.parse_args(["--count", "-1"]))
    assert err.value.renamed(flag_name) == "--count must be a positive integer, got -1"
    base = Demo(count=7)  # a command's own defaults
    assert spec_from_args(Demo, parser.parse_args([]), base=base).count == 7


def test_flags_a_mode_does_not_use_are_refused():
    parser = argparse.ArgumentParser()
    add_spec_flags(parser, Demo)
    args = parser.parse_args(["--weight", "0.5", "--count", "2"])
    assert given(args, "weight", "count", "rate_hz") == ["--weight", "--count"]
    with pytest.raises(InputError, match=r"--weight, --count are not used when streaming"):
        refuse_unused(args, ["weight", "count"], "when streaming")
    refuse_unused(args, ["rate_hz"], "when streaming")  # not given: fine


def test_mesh_spec_resolves_against_the_robot(three_cable):
    assert MeshSpec().resolve(three_cable) == (three_cable.n_rings, three_cable.n_axial)
    assert MeshSpec(n_axial=4).resolve(three_cable) == (three_cable.n_rings, 4)
    with pytest.raises(InputError, match="MeshSpec.n_rings must be a positive integer"):
        MeshSpec(n_rings=0)
    with pytest.raises(InputError, match="would need about"):
        MeshSpec(n_rings=2000, n_axial=100000).resolve(three_cable)  # refused before any work


def test_a_cross_field_rule_lives_in_the_spec_and_reads_as_flags_on_the_command_line():
    """``track``'s mode rules are written once, in TrackSpec; the command line names the flags."""
    from lab.cli import build_parser
    from lab.cli.flags import flag_text
    from lab.jobs.track import TrackSpec

    build_parser()  # the commands declare their flags
    with pytest.raises(FieldError) as err:
        TrackSpec(trajectory="circle", closed_loop="ilc", stream=StreamSpec(period_s=5.0))
    assert err.value.spec == "TrackSpec" and err.value.fields == ("stream", "closed_loop")
    assert str(err.value).startswith("TrackSpec.stream streams open loop or feed-forward")
    assert flag_text(str(err.value)) == (
        "--period-s streams open loop or feed-forward; it does not combine with --closed-loop"
    )
    spec = TrackSpec(trajectory="circle", model="m.npz", max_spread_mm=2.0)
    assert spec.ik.max_spread_m == pytest.approx(2e-3)  # the spec converts mm to the IK's metres
    with pytest.raises(FieldError, match=r"^TrackSpec.max_spread_mm must be finite and > 0, got -1.0 mm$"):
        TrackSpec(trajectory="circle", model="m.npz", max_spread_mm=-1.0)
