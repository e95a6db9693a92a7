"""Fault-sweep rows (tests/sweep.py format) for rig none: filled in by its owner."""

from sweep import Case  # noqa: F401

RIG_NONE_CASES: list = []
