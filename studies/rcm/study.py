"""What the RCM admittance-control study adds to certiloop: models, the generated guard, the push
search (`certiloop falsify rcm.push_*`)."""

from certiloop.models.library.registry import Study

HERE = "certiloop.studies.rcm"

STUDY = Study(
    name="rcm",
    title=("A passive admittance controller to enforce Remote Center of Motion and Tool Spatial"
           " constraints with application in hands-on surgical procedures"),
    order=40,
    package=HERE,
    models={
        "rcm.nullspace": f"{HERE}.models.constraint:nullspace",
        "rcm.nullspace_wrong_sign": f"{HERE}.models.constraint:nullspace_wrong_sign",
        "rcm.decoupling": f"{HERE}.models.constraint:decoupling",
        "rcm.decoupling_zw_mapping": f"{HERE}.models.constraint:decoupling_zw_mapping",
        "rcm.constraint_set_invariant": f"{HERE}.models.constraint:constraint_set_invariant",
        "rcm.constraint_exponential": f"{HERE}.models.constraint:constraint_exponential",
        "rcm.constraint_euler_4ms": f"{HERE}.models.constraint:constraint_euler_4ms",
        "rcm.constraint_euler_stiff": f"{HERE}.models.constraint:constraint_euler_stiff",
        "rcm.barrier_continuous": f"{HERE}.models.constraint:barrier_continuous",
        "rcm.barrier_clearance": f"{HERE}.models.constraint:barrier_clearance",
        "rcm.damping_bounds": f"{HERE}.models.constraint:damping_bounds",
        "rcm.axial_euler_4ms": f"{HERE}.models.constraint:axial_euler_4ms",
        "rcm.barrier_off_s": f"{HERE}.models.constraint:barrier_off_s",
        "rcm.axial_guard": f"{HERE}.models.constraint:axial_guard",
        "rcm.axial_guard_half_margin": f"{HERE}.models.constraint:axial_guard_half_margin",
        "rcm.passivity": f"{HERE}.models.energy:passivity",
        "rcm.passivity_step_midpoint": f"{HERE}.models.energy:passivity_step_midpoint",
        "rcm.passivity_step_explicit": f"{HERE}.models.energy:passivity_step_explicit",
        "rcm.passivity_negative_damping": f"{HERE}.models.energy:passivity_negative_damping",
        "rcm.passivity_nonconservative": f"{HERE}.models.energy:passivity_nonconservative",
        "rcm.capsule_nearest_point": f"{HERE}.models.energy:capsule_nearest_point",
        "rcm.capsule_unclamped": f"{HERE}.models.energy:capsule_unclamped",
        "rcm.capsule_continuous": f"{HERE}.models.energy:capsule_continuous",
        "rcm.clearance_unbounded_energy": f"{HERE}.models.energy:clearance_unbounded_energy",
        "rcm.cloud_cover": f"{HERE}.models.energy:cloud_cover",
        "rcm.cloud_cover_half_spacing": f"{HERE}.models.energy:cloud_cover_half_spacing",
        "rcm.constraint_euler_lyapunov": f"{HERE}.models.lyapunov:constraint_euler_lyapunov",
        "rcm.constraint_euler_lyapunov_stiff": f"{HERE}.models.lyapunov:constraint_euler_lyapunov_stiff",
    },
    falsify={"rcm.push": f"{HERE}.push_cli:run"},
    generated={"rcm.axial_guard": ("generated/axial_guard.py", "")},
)
