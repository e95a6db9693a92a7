"""Fault-sweep rows (tests/sweep.py format) for inspect: filled in by its owner."""

from sweep import Case  # noqa: F401

INSPECT_CASES: list = []
