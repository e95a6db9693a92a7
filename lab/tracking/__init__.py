"""Stage 9b: following a trajectory on a rig, and the paper's Table I.

:func:`run_trajectory` (:mod:`.track`) solves the IK for every target, sends the commands
to any :class:`lab.rig.Rig` and records where the tip settled; :mod:`.table1` merges the
mean errors into ``table1.csv``. :mod:`.transfer_study` measures the sim-to-real curve
(error against the number of real samples, per transfer method) on emulated as-built robots.
"""

from lab.tracking.closed_loop import (
    DEFAULT_GAIN,
    Correction,
    TipMeasurement,
    correct_command,
    damped_pinv,
    measure_tip,
    run_closed_loop,
    tip_from_frames,
)
from lab.tracking.data_curve import (
    STRATEGIES,
    NominalBody,
    data_curve_row,
    heldout_set,
    hours_saved,
    make_body,
    plan_rows,
)
from lab.tracking.period_curve import PERIOD_CURVE_COLUMNS, period_curve_rows, read_period_curve, write_period_curve
from lab.tracking.stream import StreamPlan, StreamResult, plan_stream, stream_trajectory, target_at
from lab.tracking.table1 import (
    COLUMNS,
    CONDITIONS,
    PAPER_CM,
    SHAPES,
    Table1Error,
    read_table1,
    render_markdown,
    update_table1,
)
from lab.tracking.track import (
    REQUIRED_KEYS,
    TRACK_PROTOCOL,
    TrackResult,
    TrackResultError,
    make_solver,
    read_result,
    run_trajectory,
    write_result,
)
from lab.tracking.transfer_study import (
    METHOD_MIN_N,
    curve_rows,
    defect_variants,
    evaluate_model,
    family_table1,
    findings,
    make_methods,
    quasi_static_tips,
    random_safe_commands,
    read_curve,
    smallest_n,
)

__all__ = [
    "DEFAULT_GAIN",
    "Correction",
    "TipMeasurement",
    "correct_command",
    "damped_pinv",
    "measure_tip",
    "run_closed_loop",
    "tip_from_frames",
    "STRATEGIES",
    "NominalBody",
    "data_curve_row",
    "heldout_set",
    "hours_saved",
    "make_body",
    "plan_rows",
    "TRACK_PROTOCOL",
    "REQUIRED_KEYS",
    "TrackResultError",
    "TrackResult",
    "run_trajectory",
    "write_result",
    "read_result",
    "make_solver",
    "SHAPES",
    "PAPER_CM",
    "CONDITIONS",
    "COLUMNS",
    "Table1Error",
    "read_table1",
    "update_table1",
    "render_markdown",
    "METHOD_MIN_N",
    "curve_rows",
    "defect_variants",
    "evaluate_model",
    "family_table1",
    "findings",
    "make_methods",
    "quasi_static_tips",
    "random_safe_commands",
    "read_curve",
    "smallest_n",
    "StreamPlan",
    "StreamResult",
    "plan_stream",
    "stream_trajectory",
    "target_at",
    "PERIOD_CURVE_COLUMNS",
    "period_curve_rows",
    "read_period_curve",
    "write_period_curve",
]
