"""How the command line spells a spec field where argparse's defaults do not.

A spec field ``Class.field`` becomes the flag ``--field`` (underscores as dashes) with the
metavar argparse makes of it (:mod:`.flags`). :data:`SPELLING` lists the fields whose flag
is spelt otherwise or whose metavar names the value (``--random SEED``), and the argparse
keywords a field's type alone does not give; :data:`TYPED` the flags a command declares by
hand for a spec field (``--rig``, ``--model``), so that an error naming the field names
the flag the user typed. Stages never see this table.
"""

from __future__ import annotations

__all__ = ["SPELLING", "TYPED", "WORDS"]

#: ``"Class.field"`` -> argparse keywords: ``flag`` (its spelling), ``metavar``, ``nargs``, ``type``.
SPELLING: dict[str, dict] = {
    "FamilyMemberSpec.seed": {"flag": "--random", "metavar": "SEED"},
    "FamilyMemberSpec.foam": {"metavar": "SEED"},
    "ProtocolSpec.kind": {"flag": "--protocol"},
    "IKConfig.method": {"flag": "--solver"},
    "DataCurveSpec.tracking": {"flag": "--no-tracking"},
    "TrainSpec.ratios": {"flag": "--split", "nargs": "+", "metavar": "SPLIT"},
    "TrainSpec.hidden": {"metavar": "WIDTH"},
    "TrainSpec.history": {"metavar": "K"},
    "TransferCurveSpec.calibration_mesh": {"metavar": ("RINGS", "AXIAL")},
    "InspectSpec.neighbours": {"metavar": "K"},
    "InspectSpec.bootstrap": {"metavar": "B"},
    "InspectSpec.outlier_mads": {"metavar": "K"},
    "InspectSpec.block_rows": {"metavar": "N"},
    "ImportSpec.u": {"metavar": "COLS"},
    "ImportSpec.y": {"metavar": "COLS"},
    "ImportSpec.group": {"metavar": "COL"},
    "ImportSpec.id": {"metavar": "COL"},
    "ImportSpec.licence": {"metavar": "TEXT"},
    "ImportSpec.source": {"metavar": "TEXT"},
    "DesignSpec.grid": {"metavar": "LEVELS"},
    "DesignSpec.sobol": {"metavar": "N"},
    "DesignSpec.lhs": {"metavar": "N"},
    "DesignSpec.active": {"metavar": "N"},
    "DesignSpec.n": {"metavar": "N"},
    "DesignSpec.batch": {"metavar": "B"},
    "DesignSpec.ensemble_members": {"metavar": "K"},
    "DesignSpec.ensemble_hidden": {"metavar": "WIDTH"},
    "DesignSpec.ensemble_epochs": {"metavar": "E"},
}

#: A stage's words for a run's own argument (not a spec field) -> the command line's words.
WORDS: dict[str, str] = {
    "choose another output file": "choose another --out",
    "several output files": "several --out files",
    "jobs (worker processes) must be": "--jobs must be",
    "floor report ": "--floor ",
    "choose another checkpoint directory": "choose another --checkpoint directory",
    "choose another checkpoint": "choose another --checkpoint",
    "restarting discards": "--restart discards",
    "without observations files": "without --observations",
    "observations files": "--observations files",
    "observations file ": "--observations ",
    "extra dataset ": "--extra-data ",
    "a forward model applies only to": "--forward only applies to",
}

#: ``"Class.field"`` -> the flag a command declares by hand for it (not from the spec).
TYPED: dict[str, str] = {
    "TrackSpec.model": "--model",
    "TrackSpec.robot": "--robot",
    "TrackSpec.seed": "--seed",
    "TrackSpec.rig": "--rig",
    "TrackSpec.stream": "--period-s",
    "TrackSpec.soft_ik": "--soft-ik",
    "RigSpec.rig": "--rig",
    "CaptureSpec.rig": "--rig",
    "DesignSpec.seed": "--seed",
}
