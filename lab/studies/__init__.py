"""Stage 10: the studies -- the paper's Table I and the beyond chapters' measured curves.

Each study runs the lower stages (models, IK, rigs, tracking) over a grid of settings and
writes one results table: :mod:`.table1` merges tracking errors into ``table1.csv``;
:mod:`.transfer_study` measures error against the number of real samples per transfer
method on emulated as-built robots (:mod:`.transfer_curve`: the resumable run over a
family); :mod:`.data_curve` measures error against the number of samples per sampling
strategy (:mod:`.data_curve_run`: the resumable run of a :class:`DataCurveSpec`);
:mod:`.model_comparison` every model side by side on one dataset (:class:`CompareSpec`,
the :mod:`.baselines`); :mod:`.capture_rate` samples per hour against accuracy per capture protocol;
:mod:`.period_curve` tracking error against the trajectory's period;
:mod:`.closed_loop_table` closed-loop result files as one row per pass.
"""

from lab.studies.baselines import fit_poly
from lab.studies.capture_rate import (
    capture_rate_study,
    protocol_for,
    read_capture_rate,
    run_protocol,
    write_capture_rate,
)
from lab.studies.closed_loop_table import GOALS_M, final_pass_by_limit, model_label, pass_rows
from lab.studies.comparison_spec import CompareSpec
from lab.studies.data_curve import NominalBody, data_curve_row, heldout_set, make_body
from lab.studies.data_curve_plan import STRATEGIES, hours_saved, plan_rows
from lab.studies.data_curve_run import run_data_curve
from lab.studies.data_curve_spec import DataCurveSpec
from lab.studies.model_comparison import read_comparison, run_comparison
from lab.studies.period_curve import PERIOD_CURVE_COLUMNS, period_curve_rows, read_period_curve, write_period_curve
from lab.studies.table1 import (
    COLUMNS,
    CONDITIONS,
    PAPER_CM,
    SHAPES,
    Table1Error,
    update_table1,
)
from lab.studies.transfer_curve import TransferCurveSpec, transfer_curve_run
from lab.studies.transfer_study import (
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
    "SHAPES",
    "PAPER_CM",
    "CONDITIONS",
    "COLUMNS",
    "Table1Error",
    "update_table1",
    "METHOD_MIN_N",
    "TransferCurveSpec",
    "transfer_curve_run",
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
    "STRATEGIES",
    "NominalBody",
    "data_curve_row",
    "heldout_set",
    "hours_saved",
    "make_body",
    "plan_rows",
    "DataCurveSpec",
    "CompareSpec",
    "run_comparison",
    "read_comparison",
    "fit_poly",
    "run_data_curve",
    "capture_rate_study",
    "protocol_for",
    "run_protocol",
    "read_capture_rate",
    "write_capture_rate",
    "PERIOD_CURVE_COLUMNS",
    "period_curve_rows",
    "read_period_curve",
    "write_period_curve",
    "GOALS_M",
    "model_label",
    "pass_rows",
    "final_pass_by_limit",
]
