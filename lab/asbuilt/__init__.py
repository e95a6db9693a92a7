"""The as-built robots (below the rigs of stage 9a): how the arm that was built differs from its description.

A *defects file* (:mod:`.arm`; fields :mod:`.fields`, validation :mod:`.parse`) says how
one as-built arm differs from its description (softness, casting gradient, eyelet shifts,
slack, play, lag, motors, motion capture, and optionally the hyperfoam law, cable
stiffness, creep, a tilted mount and a frame error); :func:`load_defects` reads one and
:func:`~lab.asbuilt.arm.as_built_fem` is its FEM. A :class:`Family` draws member ``SEED`` of
a family of such arms from a seed: :data:`RANDOM` (``twin:random:SEED``, the draws of
:mod:`.draw`), :data:`FOAM` (``twin:foam:SEED``: those plus :mod:`.foam`'s defects the
calibrator cannot fit) and :data:`PNEUMATIC` (``twin:pneumatic:SEED``: cast-silicone arms
driven by pressure chambers, :mod:`.pneumatic`; their FEM :mod:`.chambered`), each written
as a commented defects file by one writer (:mod:`.writer`); :class:`FamilyMemberSpec` is
the ``defects`` command's settings. The twin rigs that emulate these robots in time are
:mod:`lab.rig` (above this package).
Every field and range: ``docs/design/rig.md``.
"""

from __future__ import annotations

from lab.asbuilt.arm import Defects, DefectsError, load_defects, parse_defects
from lab.asbuilt.family import FAMILIES, FOAM, PNEUMATIC, RANDOM, Family, family_member
from lab.asbuilt.member_spec import FamilyMemberSpec

__all__ = [
    "Defects",
    "DefectsError",
    "load_defects",
    "parse_defects",
    "Family",
    "RANDOM",
    "FOAM",
    "PNEUMATIC",
    "FAMILIES",
    "family_member",
    "FamilyMemberSpec",
]
