"""The model library: dotted names -> theorem builders, in the order `certiloop list` shows."""

from __future__ import annotations

import difflib
from typing import Callable

from certiloop.models.lang.terms import ModelError
from certiloop.models.lang.theorem import Theorem
from certiloop.models.library import (
    cfmpa,
    cfmpa_geometry,
    cfmpa_motion,
    cfmpa_paths,
    raven,
    rcm,
    rcm_energy,
    rcm_lyapunov,
    sbs,
    textbook,
)

_BUILDERS: dict[str, Callable[[], Theorem]] = {
    "sbs.ctrl1": sbs.ctrl1,
    "sbs.ctrl1_broken": sbs.ctrl1_broken,
    "sbs.immediate": sbs.immediate,
    "sbs.predictive": sbs.predictive,
    "sbs.predictive_multi": sbs.predictive_multi,
    "sbs.eqn12": sbs.eqn12,
    "sbs.ctrl2_2d": sbs.ctrl2_2d,
    "sbs.ctrl2": sbs.ctrl2,
    "sbs.ctrl2_dynamic": sbs.ctrl2_dynamic,
    "sbs.ctrl2_wrong_k": sbs.ctrl2_wrong_k,
    "sbs.ctrl2_last_wins": sbs.ctrl2_last_wins,
    "sbs.ctrl2_dynamic_join_anywhere": sbs.ctrl2_dynamic_join_anywhere,
    "cfmpa.builtdr": cfmpa.builtdr,
    "cfmpa.builtdr_skips_last_row": cfmpa.builtdr_skips_last_row,
    "cfmpa.builtdr_inclusive": cfmpa.builtdr_inclusive,
    "cfmpa.property8": cfmpa.property8,
    "cfmpa.property8_converse": cfmpa.property8_converse,
    "cfmpa.segment_printed": cfmpa_geometry.segment_printed,
    "cfmpa.halfspace_convex": cfmpa_geometry.halfspace_convex,
    "cfmpa.hull_in_halfplane": cfmpa_geometry.hull_in_halfplane,
    "cfmpa.sat_separates": cfmpa_geometry.sat_separates,
    "cfmpa.arc_in_chord_hull": cfmpa_geometry.arc_in_chord_hull,
    "cfmpa.arc_in_triangle": cfmpa_geometry.arc_in_triangle,
    "cfmpa.joint_box_monotone": cfmpa_geometry.joint_box_monotone,
    "cfmpa.property3_printed": cfmpa_paths.property3_printed,
    "cfmpa.property3": cfmpa_paths.property3,
    "cfmpa.property4": cfmpa_paths.property4,
    "cfmpa.property5_unguarded": cfmpa_paths.property5_unguarded,
    "cfmpa.searchoptpath": cfmpa_paths.searchoptpath,
    "cfmpa.early_arrival": cfmpa_paths.early_arrival,
    "cfmpa.check_path": cfmpa_paths.check_path,
    "cfmpa.execution": cfmpa_motion.execution,
    "cfmpa.execution_original": cfmpa_motion.execution_original,
    "cfmpa.original_backward_half_unreachable": cfmpa_motion.original_backward_half_unreachable,
    "cfmpa.execution_wrong_direction": cfmpa_motion.execution_wrong_direction,
    "cfmpa.execution_layers_floor": cfmpa_motion.execution_layers_floor,
    "cfmpa.execution_grid_floor": cfmpa_motion.execution_grid_floor,
    "cfmpa.execution_early_arrival": cfmpa_motion.execution_early_arrival,
    "cfmpa.execution_pose_only": cfmpa_motion.execution_pose_only,
    "cfmpa.execution_segment_original": cfmpa_motion.execution_segment_original,
    "cfmpa.execution_segment_modified": cfmpa_motion.execution_segment_modified,
    "cfmpa.segment_modified_full_speed": cfmpa_motion.segment_modified_full_speed,
    "textbook.bouncing_ball": textbook.bouncing_ball,
    "textbook.bouncing_ball_superelastic": textbook.bouncing_ball_superelastic,
    "textbook.train": textbook.train,
    "textbook.train_no_lookahead": textbook.train_no_lookahead,
    "textbook.water_tank": textbook.water_tank,
    "textbook.water_tank_late_check": textbook.water_tank_late_check,
    "textbook.cart_forward": textbook.cart_forward,
    "textbook.cart_may_brake": textbook.cart_may_brake,
    "rcm.nullspace": rcm.nullspace,
    "rcm.nullspace_wrong_sign": rcm.nullspace_wrong_sign,
    "rcm.decoupling": rcm.decoupling,
    "rcm.decoupling_zw_mapping": rcm.decoupling_zw_mapping,
    "rcm.constraint_set_invariant": rcm.constraint_set_invariant,
    "rcm.constraint_exponential": rcm.constraint_exponential,
    "rcm.constraint_euler_4ms": rcm.constraint_euler_4ms,
    "rcm.constraint_euler_stiff": rcm.constraint_euler_stiff,
    "rcm.barrier_continuous": rcm.barrier_continuous,
    "rcm.barrier_clearance": rcm.barrier_clearance,
    "rcm.damping_bounds": rcm.damping_bounds,
    "rcm.axial_euler_4ms": rcm.axial_euler_4ms,
    "rcm.barrier_off_s": rcm.barrier_off_s,
    "rcm.axial_guard": rcm.axial_guard,
    "rcm.axial_guard_half_margin": rcm.axial_guard_half_margin,
    "rcm.passivity": rcm_energy.passivity,
    "rcm.passivity_step_midpoint": rcm_energy.passivity_step_midpoint,
    "rcm.passivity_step_explicit": rcm_energy.passivity_step_explicit,
    "rcm.passivity_negative_damping": rcm_energy.passivity_negative_damping,
    "rcm.passivity_nonconservative": rcm_energy.passivity_nonconservative,
    "rcm.capsule_nearest_point": rcm_energy.capsule_nearest_point,
    "rcm.capsule_unclamped": rcm_energy.capsule_unclamped,
    "rcm.capsule_continuous": rcm_energy.capsule_continuous,
    "rcm.clearance_unbounded_energy": rcm_energy.clearance_unbounded_energy,
    "rcm.cloud_cover": rcm_energy.cloud_cover,
    "rcm.cloud_cover_half_spacing": rcm_energy.cloud_cover_half_spacing,
    "rcm.constraint_euler_lyapunov": rcm_lyapunov.constraint_euler_lyapunov,
    "rcm.constraint_euler_lyapunov_stiff": rcm_lyapunov.constraint_euler_lyapunov_stiff,
    "raven.deviation_stop": raven.deviation_stop,
    "raven.deviation_small_margin": raven.deviation_small_margin,
    "raven.deviation_stop_3d": raven.deviation_stop_3d,
    "raven.deviation_haptic_only": raven.deviation_haptic_only,
    "raven.residual_drift": raven.residual_drift,
    "raven.jump_detected": raven.jump_detected,
    "raven.jump_above_tol": raven.jump_above_tol,
    "raven.haptic_force": raven.haptic_force,
}


def names() -> list[str]:
    return list(_BUILDERS)


def get(name: str) -> Theorem:
    try:
        builder = _BUILDERS[name]
    except KeyError:
        close = difflib.get_close_matches(name, list(_BUILDERS), n=3, cutoff=0.6)
        hint = f"; did you mean {', '.join(close[:3])}?" if close else "; `certiloop list` shows them"
        raise ModelError(f"unknown model {name!r}{hint}") from None
    theorem = builder()
    if theorem.name != name:
        raise ModelError(f"library entry {name} builds a theorem named {theorem.name}")
    return theorem
