"""What the Raven-II study adds to certiloop: models, fault-injection campaigns, FMT* planning."""

from certiloop.models.library.registry import Study

HERE = "certiloop.studies.raven"

STUDY = Study(
    name="raven",
    title="Surgeon Training in Telerobotic Surgery via a Hardware-in-the-Loop Simulator",
    order=50,
    package=HERE,
    models={
        "raven.deviation_stop": f"{HERE}.models:deviation_stop",
        "raven.deviation_small_margin": f"{HERE}.models:deviation_small_margin",
        "raven.deviation_stop_3d": f"{HERE}.models:deviation_stop_3d",
        "raven.deviation_haptic_only": f"{HERE}.models:deviation_haptic_only",
        "raven.residual_drift": f"{HERE}.models:residual_drift",
        "raven.jump_detected": f"{HERE}.models:jump_detected",
        "raven.jump_above_tol": f"{HERE}.models:jump_above_tol",
        "raven.haptic_force": f"{HERE}.models:haptic_force",
    },
    commands={"campaign": f"{HERE}.campaign.cli:COMMAND",
              "plan": f"{HERE}.plan_cli:PLAN",
              "check-path": f"{HERE}.plan_cli:CHECK_PATH"},
)
