"""What the dual-arm planner study adds to certiloop: the `cfmpa.*` models and generated algorithms."""

from certiloop.models.library.registry import Study

HERE = "certiloop.studies.dualarm"

STUDY = Study(
    name="dualarm",
    title="Formal Verification of a Collision-free Algorithm of Dual-arm Robot in HOL4",
    order=20,
    package=HERE,
    models={
        "cfmpa.builtdr": f"{HERE}.models.builtdr:builtdr",
        "cfmpa.builtdr_skips_last_row": f"{HERE}.models.builtdr:builtdr_skips_last_row",
        "cfmpa.builtdr_inclusive": f"{HERE}.models.builtdr:builtdr_inclusive",
        "cfmpa.property8": f"{HERE}.models.builtdr:property8",
        "cfmpa.property8_converse": f"{HERE}.models.builtdr:property8_converse",
        "cfmpa.segment_printed": f"{HERE}.models.geometry:segment_printed",
        "cfmpa.halfspace_convex": f"{HERE}.models.geometry:halfspace_convex",
        "cfmpa.hull_in_halfplane": f"{HERE}.models.geometry:hull_in_halfplane",
        "cfmpa.sat_separates": f"{HERE}.models.geometry:sat_separates",
        "cfmpa.arc_in_chord_hull": f"{HERE}.models.geometry:arc_in_chord_hull",
        "cfmpa.arc_in_triangle": f"{HERE}.models.geometry:arc_in_triangle",
        "cfmpa.joint_box_monotone": f"{HERE}.models.geometry:joint_box_monotone",
        "cfmpa.property3_printed": f"{HERE}.models.paths:property3_printed",
        "cfmpa.property3": f"{HERE}.models.paths:property3",
        "cfmpa.property4": f"{HERE}.models.paths:property4",
        "cfmpa.property5_unguarded": f"{HERE}.models.paths:property5_unguarded",
        "cfmpa.searchoptpath": f"{HERE}.models.paths:searchoptpath",
        "cfmpa.early_arrival": f"{HERE}.models.paths:early_arrival",
        "cfmpa.check_path": f"{HERE}.models.paths:check_path",
        "cfmpa.execution": f"{HERE}.models.motion:execution",
        "cfmpa.execution_original": f"{HERE}.models.motion:execution_original",
        "cfmpa.original_backward_half_unreachable":
            f"{HERE}.models.motion:original_backward_half_unreachable",
        "cfmpa.execution_wrong_direction": f"{HERE}.models.motion:execution_wrong_direction",
        "cfmpa.execution_layers_floor": f"{HERE}.models.motion:execution_layers_floor",
        "cfmpa.execution_grid_floor": f"{HERE}.models.motion:execution_grid_floor",
        "cfmpa.execution_early_arrival": f"{HERE}.models.motion:execution_early_arrival",
        "cfmpa.execution_pose_only": f"{HERE}.models.motion:execution_pose_only",
        "cfmpa.execution_segment_original": f"{HERE}.models.motion:execution_segment_original",
        "cfmpa.execution_segment_modified": f"{HERE}.models.motion:execution_segment_modified",
        "cfmpa.segment_modified_full_speed": f"{HERE}.models.motion:segment_modified_full_speed",
    },
    generated={"cfmpa.builtdr": ("generated/builtdr.py", ""),
               "cfmpa.check_path": ("generated/check_path.py", "")},
)
