"""Fault-sweep rows (tests/sweep.py format) for history: filled in by its owner."""

from sweep import Case  # noqa: F401

HISTORY_CASES: list = []
