"""Fault-sweep rows (tests/sweep.py format) for import: filled in by its owner."""

from sweep import Case  # noqa: F401

IMPORT_CASES: list = []
