"""Drawing: the arm in matplotlib and meshcat (:mod:`.arm`), meshcat animations
(:mod:`.animation`) and trajectory-tracking figures (:mod:`.tracking`).
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
    centreline,
    centreline_embedding,
    notebook_iframe,
    rotation_from_y,
    segment_transforms,
)
from lab.viz.arm import (
    CABLE_RGB,
    CMAP,
    FOAM_RGB,
    TIP_RGB,
    UNITS,
    ArmGeometry,
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
    update_scene,
)
from lab.viz.tracking import (
    ACHIEVED_COLOR,
    CABLE_COLORS,
    TARGET_COLOR,
    plot_commands,
    plot_helix,
    plot_paths_3d,
    plot_tracking_row,
)

__all__ = ["FOAM_RGB", "CABLE_RGB", "TIP_RGB", "CMAP", "UNITS", "ArmGeometry", "arm_geometry", "cable_colors", "meshcat_visualizer", "stop_visualizer", "set_view", "update_scene", "meshcat_scene", "static_html", "notebook_html", "plot_arm", "plot_arm_views", "TARGET_RGB", "ACHIEVED_RGB", "CABLE_RADIUS_M", "MARKER_RADIUS_M", "centreline_embedding", "centreline", "rotation_from_y", "segment_transforms", "ArmPieces", "arm_pieces", "animate_arm", "animation_html", "notebook_iframe", "CABLE_COLORS", "TARGET_COLOR", "ACHIEVED_COLOR", "plot_commands", "plot_tracking_row", "plot_helix", "plot_paths_3d"]
