"""The typed-settings mechanism: option() declarations carry the flag, help and check; a spec
validates itself naming the flag; the command line builds its flags from the declarations and
turns parsed arguments back into the spec (lab.specs, lab.cli.flags)."""

from __future__ import annotations

import argparse
import math
from dataclasses import FrozenInstanceError, dataclass

import pytest

from lab.cli.flags import add_spec_flags, given, refuse_unused, spec_from_args
from lab.errors import InputError
from lab.fem import MeshSpec
from lab.specs import Spec, at_most, non_negative, option, positive, positive_int


@dataclass(frozen=True)
class Demo(Spec):
    rate_hz: float = option(10.0, help="sampling rate", type=float, check=at_most(200.0, positive, " Hz"))
    count: int = option(3, help="how many", type=int, check=positive_int)
    method: str = option("lm", flag="--solver", help="the solver", choices=("lm", "gd"))
    widths: tuple = option((20, 20), help="hidden widths", type=int, nargs="+")
    weight: float | None = option(None, help="a weight", type=float, check=non_negative)
    internal: int = option(0, help="not a flag", cli=False)


def test_a_spec_refuses_bad_values_naming_the_flag():
    with pytest.raises(InputError, match=r"--rate-hz must be finite and > 0, got nan"):
        Demo(rate_hz=math.nan)
    with pytest.raises(InputError, match=r"--rate-hz must be at most 200 Hz, got 1000000000.0"):
        Demo(rate_hz=1e9)
    with pytest.raises(InputError, match=r"--count must be a positive integer, got 0"):
        Demo(count=0)
    with pytest.raises(InputError, match=r"--count must be a positive integer, got True"):
        Demo(count=True)  # a bool is not a count
    with pytest.raises(InputError, match=r"--solver \(method\) must be one of lm, gd, got 'bfgs'"):
        Demo(method="bfgs")
    with pytest.raises(InputError, match=r"--weight must be finite and >= 0, got -1"):
        Demo(weight=-1.0)
    assert Demo(weight=None).weight is None  # None means "not set": no check
    with pytest.raises(FrozenInstanceError):
        Demo().count = 4
    with pytest.raises(InputError, match="--count"):
        Demo().replace(count=-2)  # a copy is validated again


def test_flags_come_from_the_declarations_and_round_trip():
    parser = argparse.ArgumentParser()
    add_spec_flags(parser, Demo)
    flags = {o for a in parser._actions for o in a.option_strings}
    assert {"--rate-hz", "--count", "--solver", "--widths", "--weight"} <= flags and "--internal" not in flags
    helps = {a.dest: a.help for a in parser._actions}
    assert helps["rate_hz"] == "sampling rate (default: 10.0)" and helps["widths"] == "hidden widths (default: 20 20)"
    assert spec_from_args(Demo, parser.parse_args([])) == Demo()  # unset flags: the spec's defaults
    args = parser.parse_args(["--rate-hz", "50", "--solver", "gd", "--widths", "8", "4"])
    assert spec_from_args(Demo, args) == Demo(rate_hz=50.0, method="gd", widths=(8, 4))
    with pytest.raises(InputError, match="--count"):
        spec_from_args(Demo, parser.parse_args(["--count", "-1"]))
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
    with pytest.raises(InputError, match="--n-rings must be a positive integer"):
        MeshSpec(n_rings=0)
    with pytest.raises(InputError, match="would need about"):
        MeshSpec(n_rings=2000, n_axial=100000).resolve(three_cable)  # refused before any work
