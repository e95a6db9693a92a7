"""The commands' jobs: one module per command of ``python -m lab``, one entry point each.

Each module holds the frozen spec the command's settings cross in (or names the stage's
spec it takes) and one ``run(spec, ...)`` that does the work: reads the inputs, calls the
stages, writes the outputs and returns what the command prints. The command line
(:mod:`lab.cli`, module ``lab/cli/<command>.py``) adds the flags, builds the spec, checks
the paths and calls ``lab.jobs.<command>.run`` (:data:`JOBS` maps a command's name to its
module); a notebook calls the same function with a
spec it builds in Python. Jobs never import each other: what two share lives in a stage.

Above the stages they call (data, learn, rig, transfer, tracking, studies) and below the
course and the command line.
"""

from lab.jobs import (
    calibrate,
    capture,
    compare,
    data_curve,
    defects,
    fit_dynamics,
    import_data,
    inspect,
    simulate,
    splits,
    track,
    train,
    transfer,
    transfer_curve,
)

__all__ = ["JOBS"]

#: The job module of each command of :data:`lab.cli.COMMANDS`, by the command's name.
JOBS = {
    "simulate": simulate,
    "import-data": import_data,
    "inspect": inspect,
    "compare": compare,
    "train": train,
    "splits": splits,
    "track": track,
    "capture": capture,
    "defects": defects,
    "transfer": transfer,
    "transfer-curve": transfer_curve,
    "data-curve": data_curve,
    "calibrate": calibrate,
    "fit-dynamics": fit_dynamics,
}
