"""Drawing, to one visual standard (:mod:`.style`, docs/figures.md): the arm in matplotlib
and meshcat (:mod:`.arm`), meshcat animations (:mod:`.animation`), trajectory-tracking
figures (:mod:`.tracking`), Figure 1's set-up (:mod:`.setup`), Figure 6
(:mod:`.network_size`), the interactive arm of chapter 01 (:mod:`.sliders`), the live
meshcat viewer a kernel serves (:mod:`.live`, :mod:`.live_arm`), still images of the 3-D
scenes for pages that run none (:mod:`.stills`), a dataset's diagnostics (:mod:`.real_data`)
and any body with its tendons and markers (:mod:`.bodies`).
"""

from lab.viz.animation import (
    ACHIEVED_RGB,
    CABLE_RADIUS_M,
    MARKER_RADIUS_M,
    TARGET_RGB,
    ArmPieces,
    animate_arm,
    animation_html,
    arm_pieces,
    centreline_embedding,
    notebook_iframe,
)
from lab.viz.arm import (
    CABLE_RGB,
    CMAP,
    FOAM_RGB,
    TIP_RGB,
    UNITS,
    arm_geometry,
    cable_colors,
    meshcat_scene,
    meshcat_visualizer,
    notebook_html,
    plot_arm,
    plot_arm_views,
    set_view,
    static_html,
    stop_visualizer,
)
from lab.viz.bodies import MARKER_COLORS, TENDON_COLORS, plot_body, plot_body_views
from lab.viz.capture_rate import PROTOCOL_STYLES, plot_capture_rate
from lab.viz.closed_loop import MODEL_COLORS, TRAJECTORY_MARKERS, plot_closed_loop, plot_passes
from lab.viz.dynamics import MODE_STYLES, plot_period_curve, plot_streamed_trajectory
from lab.viz.efficiency import METRIC_LABELS, plot_calibration, plot_error_vs_n
from lab.viz.ik_picker import IKPicker
from lab.viz.live import live_viewer, live_viewer_wanted
from lab.viz.live_arm import LiveArm, show_animation, show_arm
from lab.viz.network_size import plot_network_size, plot_stopping
from lab.viz.placement import plot_trajectory_placement
from lab.viz.real_data import AXIS_COLORS, plot_diagnostics
from lab.viz.setup import plot_setup
from lab.viz.sliders import ArmExplorer, widgets_available
from lab.viz.square_frames import plot_square_frames
from lab.viz.stills import SceneView, animation_still, arm_still
from lab.viz.style import (
    ACHIEVED_COLOR,
    CABLE_COLORS,
    GOAL_STYLE,
    LIMIT_STYLE,
    METHOD_COLORS,
    MODEL_COLOR,
    PAPER_COLOR,
    PAPER_DASHES,
    SERIES_COLORS,
    SIM_ONLY_COLOR,
    SIM_ONLY_STYLE,
    STRATEGY_COLORS,
    TARGET_COLOR,
    achieved_kw,
    legend_outside,
    mean_and_range,
    paper_style,
    plain_log_ticks,
    target_kw,
)
from lab.viz.tracking import (
    plot_figure3,
    plot_helix,
    plot_paths_3d,
    plot_tracking_row,
)
from lab.viz.training import plot_lm_training
from lab.viz.transfer import PAPER_MEAN_CM, plot_transfer_curve

__all__ = [
    "TARGET_COLOR",
    "ACHIEVED_COLOR",
    "MODEL_COLOR",
    "SIM_ONLY_COLOR",
    "PAPER_COLOR",
    "PAPER_DASHES",
    "SIM_ONLY_STYLE",
    "SERIES_COLORS",
    "CABLE_COLORS",
    "METHOD_COLORS",
    "STRATEGY_COLORS",
    "GOAL_STYLE",
    "LIMIT_STYLE",
    "target_kw",
    "achieved_kw",
    "paper_style",
    "plain_log_ticks",
    "legend_outside",
    "mean_and_range",
    "MARKER_COLORS",
    "TENDON_COLORS",
    "plot_body",
    "plot_body_views",
    "FOAM_RGB",
    "CABLE_RGB",
    "TIP_RGB",
    "CMAP",
    "UNITS",
    "arm_geometry",
    "cable_colors",
    "meshcat_visualizer",
    "stop_visualizer",
    "set_view",
    "meshcat_scene",
    "static_html",
    "notebook_html",
    "plot_arm",
    "plot_arm_views",
    "TARGET_RGB",
    "ACHIEVED_RGB",
    "CABLE_RADIUS_M",
    "MARKER_RADIUS_M",
    "centreline_embedding",
    "ArmPieces",
    "arm_pieces",
    "animate_arm",
    "animation_html",
    "notebook_iframe",
    "plot_tracking_row",
    "plot_figure3",
    "plot_helix",
    "plot_paths_3d",
    "plot_setup",
    "ArmExplorer",
    "widgets_available",
    "IKPicker",
    "LiveArm",
    "show_arm",
    "show_animation",
    "SceneView",
    "arm_still",
    "animation_still",
    "live_viewer",
    "live_viewer_wanted",
    "plot_square_frames",
    "plot_trajectory_placement",
    "plot_lm_training",
    "plot_network_size",
    "plot_stopping",
    "PAPER_MEAN_CM",
    "plot_transfer_curve",
    "METRIC_LABELS",
    "plot_calibration",
    "plot_error_vs_n",
    "MODEL_COLORS",
    "TRAJECTORY_MARKERS",
    "plot_closed_loop",
    "plot_passes",
    "PROTOCOL_STYLES",
    "plot_capture_rate",
    "MODE_STYLES",
    "plot_period_curve",
    "plot_streamed_trajectory",
    "AXIS_COLORS",
    "plot_diagnostics",
]
